"""What each runtime path costs per pixel, against three.js's own `evalIridescence`.

1. SPIR-V arithmetic (the figure that carries to a GPU, where filtered reads run on texture units): each
   path's GLSL in a fragment shader, `glslang -V`, loops with a fixed trip count marked [[unroll]] and
   unrolled, `spirv-opt -O`; counted: every arithmetic, comparison, logical, select, conversion and
   GLSL.std.450 instruction, weighted by its result's components (a vec3 multiply counts 3, a mat3 × vec3
   15: 9 multiplies and 6 adds); not counted: loads, stores, composites, shuffles, branches, phis. Also the
   transcendental calls (sqrt, exp, sin, …) and the texture instructions per pixel. The exact mode's loop
   stops on its inputs: its setup and its cost per term are counted apart.
2. Bytes on the GPU: each path's textures as three.js's EXRLoader uploads them.
3. SwiftShader (headless Chromium, WebGL2 on the CPU): every path drawn as a 512 × 512 full-screen pass,
   one evaluation per pixel, parameters varying smoothly over the screen as on a rendered surface,
   interleaved in one page (engine/page.js, lutbakeCost), each round drawing every job; per round the
   job's wall net of an empty pass divided by three.js's, the median over rounds. The drop-in on a lit
   MeshPhysicalMaterial sphere filling the screen against three.js's own iridescence, the same way.

Rerun: python bench/bench_runtime_cost.py [--rounds N] [--no-engine]
(glslang and spirv-opt from the test extra; node and Debian's chromium for part 3; writes
bench/runtime-cost-result.json)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import sysconfig
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "docs")]

PREFIX = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"
THREE_CHUNKS = ROOT / "engine" / "node_modules" / "three" / "src" / "renderers" / "shaders" / "ShaderChunk"
RESULT = ROOT / "bench" / "runtime-cost-result.json"
SHIPPED = ROOT / "lutbake" / "modes" / "runtime" / "costs.json"  # what `lutbake report` prints (runtime/costs.py)

ARITHMETIC = re.compile(
    r"Op(F|I|S|U)(Add|Sub|Mul|Div|Mod|Rem|Negate|Ord\w+|Unord\w+|Equal|NotEqual|LessThan\w*|"
    r"GreaterThan\w*)$|Op(VectorTimesScalar|MatrixTimesVector|Dot|Select|Logical\w+|Convert\w+|"
    r"ShiftRight\w+|ShiftLeft\w+|Bitwise\w+|Any|All|ExtInst)$"
)
TRANSCENDENTAL = {
    "Sqrt",
    "InverseSqrt",
    "Exp",
    "Exp2",
    "Log",
    "Log2",
    "Sin",
    "Cos",
    "Tan",
    "Asin",
    "Acos",
    "Atan",
    "Atan2",
    "Pow",
    "Length",
    "Normalize",
    "Distance",
}
TEXTURE = re.compile(r"OpImage(Sample\w*|Fetch|Gather\w*)$")


def _chunk(name: str) -> str:
    """A three.js shader chunk's GLSL (the text between the module's backticks)."""
    return (THREE_CHUNKS / f"{name}.glsl.js").read_text().split("`")[1]


def three_source() -> str:
    """three.js r187's evalIridescence with the helpers it uses from the `common` chunk."""
    common = _chunk("common")
    helpers = [line for line in common.splitlines() if line.startswith(("#define PI ", "float pow2", "vec3 pow2"))]
    schlick = [m.group(0) for m in re.finditer(r"(float|vec3) F_Schlick\(.*?\n}", common, re.S)]
    return "\n".join(helpers + schlick) + "\n#define USE_IRIDESCENCE\n" + _chunk("iridescence_fragment")


def _compile(source: str) -> str:
    """SPIR-V disassembly of a fragment shader, loops marked [[unroll]] unrolled, then spirv-opt -O."""
    env = {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
    with tempfile.TemporaryDirectory() as tmp:
        frag, spv, opt = (Path(tmp) / n for n in ("s.frag", "s.spv", "o.spv"))
        frag.write_text(source)
        for args in (
            [PREFIX / "bin" / "glslang", "-V", "-S", "frag", "-o", spv, frag],
            [PREFIX / "bin" / "spirv-opt", "--loop-unroll", "-O", spv, "-o", opt],
        ):
            out = subprocess.run([str(a) for a in args], capture_output=True, text=True, env=env)
            if out.returncode:
                raise RuntimeError(out.stdout + out.stderr)
        return subprocess.run(
            [str(PREFIX / "bin" / "spirv-dis"), str(opt)], capture_output=True, text=True, env=env, check=True
        ).stdout


def _blocks(text: str):
    """Basic blocks of the disassembly: {label: (instruction lines, successor labels)}, and loop headers
    {header: merge label}."""
    blocks, loops, label, lines = {}, {}, None, []
    for line in text.splitlines():
        m = re.match(r"\s*(%\w+) = OpLabel", line)
        if m:
            label, lines = m.group(1), []
            continue
        if label is None:
            continue
        lines.append(line)
        merge = re.search(r"OpLoopMerge (%\w+)", line)
        if merge:
            loops[label] = merge.group(1)
        if re.search(r"Op(Branch|BranchConditional|Switch|Return|ReturnValue|Kill|Unreachable)\b", line):
            targets = re.findall(r"(%\w+)", line.split("Op", 1)[1]) if "Branch" in line or "Switch" in line else []
            blocks[label] = (lines, [t for t in targets if t in text])
            label = None
    return blocks, loops


def _count(lines, components) -> dict:
    arithmetic = transcendental = reads = 0
    for line in lines:
        m = re.match(r"\s*%\w+ = (Op\w+) (%\w+) ?(.*)", line)
        if not m:
            continue
        op, kind, rest = m.groups()
        if TEXTURE.match(op):
            reads += 1
        elif ARITHMETIC.match(op):
            n = components.get(kind, 1)
            if op == "OpMatrixTimesVector":
                n *= 5  # 3 × 3: 9 multiplies and 6 adds per vec3
            arithmetic += n
            if op == "OpExtInst" and rest.split()[1] in TRANSCENDENTAL:
                transcendental += n
    return {"arithmetic": arithmetic, "transcendental": transcendental, "texture_instructions": reads}


def spirv_profile(functions: str, call: str, unroll: bool = True) -> dict:
    """Counts for ``call`` (a vec3 expression of inputs p, q, r) after ``functions`` (the samplers it uses
    declared there). A loop left after unrolling (its trip count depends on the inputs) is counted apart:
    ``per_iteration`` is one pass through its blocks (both sides of a branch in it)."""
    body = re.sub(r"\bfor \(", "[[unroll]] for (", functions) if unroll else functions
    source = (
        "#version 450\n#extension GL_EXT_control_flow_attributes : require\n"
        + body
        + "\nlayout(location = 0) in highp vec4 p;\nlayout(location = 1) in highp vec4 q;\n"
        "layout(location = 2) in highp vec4 r;\nlayout(location = 0) out highp vec4 colour;\n"
        f"void main() {{ colour = vec4({call}, 1.0); }}\n"
    )
    text = _compile(source)
    components = {}
    for m in re.finditer(r"(%\w+) = OpType(Vector|Float|Int|Bool) ?(%\w+)? ?(\d+)?", text):
        components[m.group(1)] = int(m.group(4)) if m.group(2) == "Vector" else 1
    blocks, loops = _blocks(text)
    inside = set()
    for header, merge in loops.items():
        todo = [header]
        while todo:
            b = todo.pop()
            if b in inside or b == merge or b not in blocks:
                continue
            inside.add(b)
            todo += blocks[b][1]
    total = _count([line for lines, _ in blocks.values() for line in lines], components)
    loop = _count([line for b in inside for line in blocks[b][0]], components)
    out = {k: total[k] - loop[k] for k in total}
    out["loops"] = len(loops)
    if loops:
        out["per_iteration"] = loop
    return out


def belcour_barla_source() -> str:
    """Belcour & Barla (2017) as lutbake.modes.approximations.belcour_barla_rgb evaluates it (orders 0–3, exact
    dielectric and Born & Wolf conductor Fresnel terms, XYZ adapted to Rec.709), as GLSL: a port for this
    benchmark (not shipped), checked against the numpy at random points by `python bench/bench_runtime_cost.py`."""
    from lutbake.modes.approximations import _NORM, _POS, _VAL, _VAR, _X2, _to_space

    matrix = _to_space(np.eye(3), "rec709", "cie1931")  # rows: XYZ unit vectors → RGB
    columns = ", ".join(f"{v:.9g}" for v in matrix.ravel())
    return f"""
const highp mat3 BB_XYZ_TO_RGB = mat3({columns});
highp vec3 bb_sensitivity(highp float opd, highp float shift) {{
    highp float phase = 6.283185307179586 * opd * 1e-9;
    highp vec3 val = vec3({_VAL[0]:.5g}, {_VAL[1]:.5g}, {_VAL[2]:.5g});
    highp vec3 pos = vec3({_POS[0]:.5g}, {_POS[1]:.5g}, {_POS[2]:.5g});
    highp vec3 var = vec3({_VAR[0]:.5g}, {_VAR[1]:.5g}, {_VAR[2]:.5g});
    highp vec3 xyz = val * sqrt(6.283185307179586 * var) * cos(pos * phase + shift) * exp(-var * phase * phase);
    xyz.x += {_X2[0]:.5g} * sqrt(6.283185307179586 * {_X2[2]:.5g}) * cos({_X2[1]:.5g} * phase + shift)
             * exp(-{_X2[2]:.5g} * phase * phase);
    return xyz / {_NORM:.5g};
}}
void bb_dielectric(highp float cos1, highp float n1, highp float n2, out highp vec2 r, out highp vec2 phi) {{
    highp float sin2 = 1.0 - cos1 * cos1;
    highp float nr = n1 / n2;
    bool tir = nr * nr * sin2 > 1.0;
    highp float cos2 = sqrt(max(1.0 - nr * nr * sin2, 0.0));
    highp vec2 amp = vec2((n2 * cos1 - n1 * cos2) / (n2 * cos1 + n1 * cos2),
                          (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2));
    highp float root = sqrt(max(sin2 - 1.0 / (nr * nr), 0.0)) / cos1;
    r = tir ? vec2(1.0) : amp * amp;
    phi = tir ? vec2(2.0 * atan(-nr * nr * root), 2.0 * atan(-root)) : vec2(amp.x < 0.0 ? 3.141592653589793 : 0.0,
                                                                             amp.y < 0.0 ? 3.141592653589793 : 0.0);
}}
void bb_conductor(highp float cos1, highp float n1, highp float n2, highp float k,
                  out highp vec2 r, out highp vec2 phi) {{
    if (k <= 0.0) {{ bb_dielectric(cos1, n1, n2, r, phi); return; }}
    highp float a = n2 * n2 * (1.0 - k * k) - n1 * n1 * (1.0 - cos1 * cos1);
    highp float b = sqrt(a * a + 4.0 * n2 * n2 * n2 * n2 * k * k);
    highp float u = sqrt((a + b) / 2.0), v = sqrt(max(b - a, 0.0) / 2.0);
    highp float rs = ((n1 * cos1 - u) * (n1 * cos1 - u) + v * v) / ((n1 * cos1 + u) * (n1 * cos1 + u) + v * v);
    highp float ps = atan(2.0 * n1 * v * cos1, u * u + v * v - n1 * n1 * cos1 * cos1) + 3.141592653589793;
    highp float e = n2 * n2 * (1.0 - k * k) * cos1, f = 2.0 * n2 * n2 * k * cos1;
    highp float rp = ((e - n1 * u) * (e - n1 * u) + (f - n1 * v) * (f - n1 * v))
                     / ((e + n1 * u) * (e + n1 * u) + (f + n1 * v) * (f + n1 * v));
    highp float pp = atan(2.0 * n1 * n2 * n2 * cos1 * (2.0 * k * u - (1.0 - k * k) * v),
                          (n2 * n2 * (1.0 + k * k) * cos1) * (n2 * n2 * (1.0 + k * k) * cos1)
                          - n1 * n1 * (u * u + v * v));
    r = vec2(rp, rs);
    phi = vec2(pp, ps);
}}
highp vec3 bb_iridescence(highp float cos1, highp float thickness_nm, highp float e1, highp float e2, highp float e3,
                          highp float k3) {{
    highp float opd = 2.0 * e2 * thickness_nm;
    highp float t = clamp(opd / 30.0, 0.0, 1.0);
    highp float eta2 = e1 + (e2 - e1) * t * t * (3.0 - 2.0 * t);
    highp float cos2 = sqrt(max(1.0 - (e1 / eta2) * (e1 / eta2) * (1.0 - cos1 * cos1), 0.0));
    highp vec2 r12, phi12, r23, phi23;
    bb_dielectric(cos1, e1, eta2, r12, phi12);
    bb_conductor(cos2, eta2, e3, k3 / e3, r23, phi23);
    highp vec3 xyz = vec3(0.0);
    for (int pol = 0; pol < 2; ++pol) {{
        highp float t121 = 1.0 - r12[pol];
        highp float r123 = r12[pol] * r23[pol];
        highp float rs = t121 * t121 * r23[pol] / (1.0 - r123);
        xyz += 0.5 * (r12[pol] + rs) * bb_sensitivity(0.0, 0.0);
        highp float cm = rs - t121;
        highp float phi2 = 3.141592653589793 - phi12[pol] + phi23[pol];
        for (int m = 1; m <= 3; ++m) {{
            cm *= sqrt(r123);
            xyz += 0.5 * cm * 2.0 * bb_sensitivity(float(m) * opd * cos2, float(m) * phi2);
        }}
    }}
    return BB_XYZ_TO_RGB * xyz;
}}
"""


# Parameters of every engine job (GLSL of gl_FragCoord): smooth over the screen as on a rendered surface,
# covering the domain (dielectric bases; metals in eta3m, kappa3m).
PARAMS = """
highp vec2 uv = gl_FragCoord.xy / SIZE;
highp float cos_theta = uv.x, thickness_nm = 1500.0 * uv.y;
highp float eta2 = 2.0 + sin(7.0 * uv.x + 3.0 * uv.y);
highp float eta3 = 2.0 + sin(5.0 * uv.y - 4.0 * uv.x), kappa3 = 1.0 + sin(3.0 * uv.x * uv.y + 1.0);
highp vec3 eta3m = 2.025 + 1.975 * sin(vec3(4.0, 4.5, 5.0) * uv.x + 2.0 * uv.y);
highp vec3 kappa3m = 5.25 + 3.75 * sin(vec3(3.0, 3.5, 4.0) * uv.y - uv.x);
highp vec3 f0 = vec3((eta3 - 1.0) * (eta3 - 1.0) / ((eta3 + 1.0) * (eta3 + 1.0)));   // three's F0 of the base
"""
# name: (includes, textures (uniform -> (file, float)), call, what it is)
LUT = "luts/lutbake-eta2-1.50"
RUNTIME = (["luts/runtime/lutbake-runtime.glsl"], {"rt": ("luts/runtime/lutbake-runtime.exr", False)})
EXACT = (["engine/exact/lutbake-exact.glsl"], {"ex": ("engine/exact/lutbake-exact.exr", True)})
FILM = "cos_theta, thickness_nm, 1.0, eta2"
PATHS = {
    "three": (
        [],
        {},
        "evalIridescence(1.0, eta2, cos_theta, thickness_nm, f0)",
        "three.js r187 evalIridescence (KHR_materials_iridescence)",
    ),
    "runtime": (*RUNTIME, f"lutbake_iridescence(rt, {FILM}, eta3, kappa3)", "lutbake runtime table, one base index"),
    "runtime-float": (
        RUNTIME[0],
        {"rtf": ("luts/runtime/lutbake-runtime.exr", "linear")},
        f"lutbake_iridescence(rtf, {FILM}, eta3, kappa3)",
        "lutbake runtime table, one base index, float32 texels (where OES_texture_float_linear filters them)",
    ),
    "runtime-rgb": (
        *RUNTIME,
        f"lutbake_iridescence_rgb(rt, {FILM}, eta3m, kappa3m)",
        "lutbake runtime table, per-channel metal",
    ),
    "exact": (
        *EXACT,
        f"lutbake_exact(ex, {FILM}, eta3, kappa3)",
        "lutbake exact mode (tolerance 1e-4), one base index",
    ),
    "exact-rgb": (*EXACT, f"lutbake_exact_rgb(ex, {FILM}, eta3m, kappa3m)", "lutbake exact mode, per-channel metal"),
    "lut-cubic": (
        [f"{LUT}.glsl"],
        {"lut": (f"{LUT}.exr", False)},
        "lutbake_sample(lut, LUTBAKE_ETA2_1_50, cos_theta, 3.0 * thickness_nm, eta3, kappa3)",
        "lutbake LUT read cubic (the default set's rule)",
    ),
    "lut-cubic-rgb": (
        [f"{LUT}-metal.glsl"],
        {"lutm": (f"{LUT}-metal.exr", False)},
        "vec3(lutbake_sample(lutm, LUTBAKE_ETA2_1_50_METAL, cos_theta, 3.0 * thickness_nm, eta3m.r, kappa3m.r).r,"
        " lutbake_sample(lutm, LUTBAKE_ETA2_1_50_METAL, cos_theta, 3.0 * thickness_nm, eta3m.g, kappa3m.g).g,"
        " lutbake_sample(lutm, LUTBAKE_ETA2_1_50_METAL, cos_theta, 3.0 * thickness_nm, eta3m.b, kappa3m.b).b)",
        "lutbake LUT read cubic, per-channel metal (three reads of the metal LUT)",
    ),
    "lut-linear": (
        [f"{LUT}.glsl"],
        {"lut": (f"{LUT}.exr", False)},
        "lutbake_sample_linear(lut, LUTBAKE_ETA2_1_50, cos_theta, 3.0 * thickness_nm, eta3, kappa3)",
        "lutbake LUT read by 4 bilinear fetches",
    ),
    "belcour-barla-2017": (
        ["<belcour-barla>"],
        {},
        "bb_iridescence(cos_theta, thickness_nm, 1.0, eta2, eta3, kappa3)",
        "Belcour & Barla 2017, orders 0-3 (a GLSL port of approximations.belcour_barla_rgb)",
    ),
}


def _sources(includes) -> str:
    return "\n".join(belcour_barla_source() if i == "<belcour-barla>" else (ROOT / i).read_text() for i in includes)


def _countable(name: str, functions: str) -> str:
    """The source as counted: the cubic LUT's skip of zero-weight κ3 taps goes, so its four loops unroll
    (its worst case, 256 reads, is counted; 64 at a κ3 node)."""
    return functions.replace("if (w_base == 0.0) continue;", "") if name.startswith("lut-cubic") else functions


def static_costs(names=None) -> dict:
    """SPIR-V arithmetic, transcendental calls and texture instructions per pixel of each path, its inputs
    read from shader inputs (the exact mode: outside its loop, and per term), and the bytes its textures
    take on the GPU. ``names``: only these paths."""
    declarations = (
        "highp float cos_theta = p.x, thickness_nm = p.y, eta2 = p.z, eta3 = p.w, kappa3 = q.x;\n"
        "highp vec3 eta3m = q.yzw, kappa3m = r.xyz, f0 = q.yzw;\n"
    )  # inputs as loads: nothing to count
    keys = ("arithmetic", "transcendental", "texture_instructions")

    def profile(prelude, functions, samplers, call):
        return spirv_profile(
            prelude + samplers + functions + "\nhighp vec3 lutbake_bench_call(highp vec4 p, highp vec4 q,"
            " highp vec4 r) {" + declarations + f"return {call}; }}\n",
            "lutbake_bench_call(p, q, r)",
        )

    out = {}
    for name, (includes, textures, call, label) in PATHS.items():
        if names is not None and name not in names:
            continue
        functions = _countable(
            name,
            (three_source() if name == "three" else _sources(includes)).replace(
                "uniform highp sampler2D", "// uniform"
            ),
        )
        samplers = "".join(f"layout(binding = {2 + i}) uniform highp sampler2D {t};\n" for i, t in enumerate(textures))
        counts = profile("", functions, samplers, call)
        entry = {k: counts[k] for k in (*keys, "loops", "per_iteration") if k in counts}
        entry["label"] = label
        entry["gpu_bytes"] = sum(_gpu_bytes(ROOT / f, fl) for f, fl in textures.values())
        out[name] = entry
    return out


def _gpu_bytes(path: Path, float_texels: bool) -> int:
    """Bytes three.js uploads for an EXR: RGBA, half (EXRLoader's default) or float."""
    import OpenEXR

    with OpenEXR.File(str(path)) as exr:
        (x0, y0), (x1, y1) = exr.header()["dataWindow"]
    return int((x1 - x0 + 1) * (y1 - y0 + 1)) * 4 * (4 if float_texels else 2)


def _run(command: str, spec: dict) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        job, result = Path(tmp) / "spec.json", Path(tmp) / "result.json"
        job.write_text(json.dumps(spec))
        proc = subprocess.run(
            ["node", str(ROOT / "engine" / "harness.mjs"), command, str(job), str(result)],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=3600,
        )
        if proc.returncode:
            raise RuntimeError(proc.stderr[-4000:])
        return json.loads(result.read_text())


def _ratios(times: dict, baseline: str, reference: str) -> dict:
    """Per entry: the median over rounds of (entry − baseline)/(reference − baseline), with its quartiles,
    and the median wall per pass (ms)."""
    base, ref = np.array(times[baseline]), np.array(times[reference])
    out = {}
    for name, t in times.items():
        r = (np.array(t) - base) / (ref - base)
        out[name] = {
            "ratio": float(np.median(r)),
            "ratio_quartiles": [float(np.percentile(r, 25)), float(np.percentile(r, 75))],
            "ms_per_pass": float(np.median(t)),
        }
    return out


def engine_costs(rounds: int) -> dict:
    """Every path as a 512 × 512 full-screen pass against an empty one and three.js's, interleaved."""
    size = 512
    textures, jobs = (
        {},
        [{"name": "empty", "call": "vec3(cos_theta + thickness_nm + eta2) + eta3m + kappa3m + f0 + eta3 + kappa3"}],
    )
    for name, (includes, tex, call, _) in PATHS.items():
        job = {"name": name, "call": call, "includes": [f"/{i}" for i in includes if not i.startswith("<")]}
        if name == "three":
            job["source"] = three_source()
        elif includes == ["<belcour-barla>"]:
            job["source"] = belcour_barla_source()
        textures.update({t: {"exr": f"/{f}", "float": fl} for t, (f, fl) in tex.items()})
        jobs.append(job)
    result = _run(
        "cost",
        {
            "textures": textures,
            "params": PARAMS.replace("SIZE", f"{size:.1f}"),
            "jobs": jobs,
            "size": size,
            "rounds": rounds,
            "draws": 3,
        },
    )
    return {
        "renderer": result["renderer"],
        "three": result["three"],
        "size": size,
        "rounds": rounds,
        "paths": _ratios(result["times"], "empty", "three"),
    }


DROPIN_MATERIALS = [  # (label, iridescenceIOR, thickness nm, base: an ior or a metal, LUT for the film)
    ("soap on glass", 1.33, 300.0, 1.5, "luts/lutbake-eta2-1.33"),
    ("oxide on Fe", 2.0, 250.0, "Fe", "luts/lutbake-eta2-2.00-metal"),
]
DROPIN_MODES = ["runtime", "runtime-half", "exact", "lut"]  # runtime: float32 where the context filters it


def dropin_costs(rounds: int) -> dict:
    """The drop-in on a lit MeshPhysicalMaterial sphere filling a 512 × 512 view: per material, each mode's
    wall net of the same material without iridescence, over three.js's own iridescence's; and the runtime
    table's texel type the drop-in's loader picked in this context (and why)."""
    from lutbake.modes.exact import base_rgb

    materials = []
    for label, eta2, thickness, base, lut in DROPIN_MATERIALS:
        m = {
            "label": label,
            "iridescenceIOR": eta2,
            "thickness": thickness,
            "lut": f"/{lut}",
            "runtime": "/luts/runtime/lutbake-runtime",
            "exact": "/engine/exact/lutbake-exact",
            "ior": base if isinstance(base, float) else 1.5,
        }
        if not isinstance(base, float):
            n, k = base_rgb(base)
            m["metal"] = {
                "eta": n.tolist(),
                "kappa": k.tolist(),
                "f0": (((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)).tolist(),
            }
        materials.append(m)
    result = _run(
        "dropin-cost", {"materials": materials, "modes": DROPIN_MODES, "size": 512, "rounds": rounds, "draws": 3}
    )
    out = {}
    for label, *_ in DROPIN_MATERIALS:
        times = {k.split("|")[1]: v for k, v in result["times"].items() if k.startswith(f"{label}|")}
        out[label] = _ratios(times, "none", "three")
    return {"runtime_table": result["precision"], "materials": out}


def shipped_costs(result: dict) -> dict:
    """The figures `lutbake report` prints per path: reads, SPIR-V arithmetic, GPU bytes, SwiftShader ×three."""
    engine = result["swiftshader"]
    load = result["machine"]
    where = (
        f"{engine['renderer']}, {load['cpus']} CPU cores at load average {load['load_average_start']:.1f}–"
        f"{load['load_average_end']:.1f}, {engine['size']}² pass, median of {engine['rounds']} rounds"
    )
    paths = {}
    for name, s in result["static"].items():
        loop = s.get("per_iteration")
        reads = str(s["texture_instructions"]) + (f" + {loop['texture_instructions']} per term" if loop else "")
        if name.startswith("lut-cubic"):
            reads += f" ({s['texture_instructions'] // 4} at a κ3 node)"
        paths[name] = {
            "reads": reads,
            "gpu_bytes": s["gpu_bytes"],
            "spirv_arithmetic": f"{s['arithmetic']} + {loop['arithmetic']} per term" if loop else s["arithmetic"],
            "swiftshader_x_three": round(engine["paths"][name]["ratio"], 2),
        }
    return {"measured": {"by": "python bench/bench_runtime_cost.py", "where": where}, "paths": paths}


def _load_average() -> float:
    return float(Path("/proc/loadavg").read_text().split()[0])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15, help="interleaved rounds per engine run")
    parser.add_argument("--no-engine", action="store_true", help="static counts only (no Chromium)")
    args = parser.parse_args()
    from make_dropin import bake_default_luts, write_exact_table, write_runtime_table

    bake_default_luts()
    write_exact_table()
    write_runtime_table()
    result = {"static": static_costs(), "machine": {"cpus": os.cpu_count(), "load_average_start": _load_average()}}
    if not args.no_engine:
        result["swiftshader"] = engine_costs(args.rounds)
        result["dropin"] = dropin_costs(args.rounds)
        result["machine"]["load_average_end"] = _load_average()
    RESULT.write_text(json.dumps(result, indent=2) + "\n")
    if not args.no_engine:
        SHIPPED.write_text(json.dumps(shipped_costs(result), indent=2, ensure_ascii=False) + "\n")
    three = result["static"]["three"]["arithmetic"]
    print(
        "| path | reads / pixel | SPIR-V arithmetic (× three) | GPU bytes | SwiftShader × three |\n"
        "|---|---|---|---|---|"
    )
    for name, s in result["static"].items():
        engine = result.get("swiftshader", {}).get("paths", {}).get(name)
        reads = f"{s['texture_instructions']}" + (
            f" + {s['per_iteration']['texture_instructions']} per term" if "per_iteration" in s else ""
        )
        ops = f"{s['arithmetic']}" + (f" + {s['per_iteration']['arithmetic']} per term" if "per_iteration" in s else "")
        print(
            f"| {name} | {reads} | {ops} ({s['arithmetic'] / three:.2f}) | {s['gpu_bytes'] / 2**20:.2f} MiB | "
            f"{'—' if engine is None else round(engine['ratio'], 2)} |"
        )
    dropin = result.get("dropin", {})
    if dropin:
        print(f"drop-in runtime table: {dropin['runtime_table']['chosen']} ({dropin['runtime_table']['reason']})")
    for label, modes in dropin.get("materials", {}).items():
        print(
            f"drop-in {label}: " + ", ".join(f"{m} {v['ratio']:.2f}×" for m, v in modes.items() if m not in ("none",))
        )


if __name__ == "__main__":
    main()
