"""The cost of lutbake's glTF hooks in Babylon.js (engine/lutbake-babylon-gltf.js) and PlayCanvas
(engine/lutbake-playcanvas.js lutbakeGltfOptions) against each engine's own iridescence, in one page per
engine: bench/bench_web_engines.py (`gltf-cost`) prints it, tests/engines/test_web_gltf_metals.py runs it on a
tiny render.

The asset is tests/web_metals.py's (IridescenceLamp's stand-in baked by the CLI with --route 2=bake:
material 1 an atlas slice over the runtime table's metal, material 2 a slice over a texture-driven metal's 4D
LUT), loaded four ways in one page (engine/babylon-page.js, playcanvas-page.js: the GltfCost functions):
none (the engine's loader, iridescence turned off), stock (the engine's own KHR_materials_iridescence), bake
(lutbake's hook serving the bake's routes) and runtime (every part on the runtime table); each material on a
lit sphere filling a size² float target, the variants' rounds interleaved. Each variant's fragment shader, as
the engine handed it to WebGL2, is counted as bench_runtime_cost.py counts: glslang (OpenGL SPIR-V, its
`#version 300 es` read as 310 es, locations and bindings mapped), spirv-opt -O, arithmetic weighted by
components and texture instructions over both sides of every branch (so a metallic material's dielectric and
metal terms both), loops with a fixed trip count unrolled.
"""

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from engine_harness import ROOT, run_harness
from runtime_contract import runtime_table_files
from web_engines import GLTF_PACKAGES, require_package
from web_metals import ASSET

sys.path.insert(0, str(ROOT / "bench"))
from bench_runtime_cost import PREFIX, _count  # noqa: E402  (the SPIR-V counting)

VARIANTS = ("none", "stock", "bake", "runtime")


def hook_costs(engine: str, baked: tuple, folder: Path, size: int, rounds: int, draws: int) -> dict:
    """The `ENGINE-gltf-cost` page's run on the asset baked for ``engine`` (web_metals.bake_for_engines:
    (glTF, out, manifest), inside the repository): {glTF index: {variant: {ms (median per draw), routes
    (the parts lutbake served, None for the engine's own), shader (fragment source), arithmetic,
    transcendental, texture_instructions}}}."""
    require_package(GLTF_PACKAGES[engine])
    gltf, out, _ = baked
    spec = {
        "runtime": f"/{runtime_table_files().with_suffix('').relative_to(ROOT)}",
        "asset": f"/{gltf.relative_to(ROOT)}",
        "manifest": f"/{(out / f'{ASSET}.json').relative_to(ROOT)}",
        "size": size,
        "rounds": rounds,
        "draws": draws,
    }
    folder.mkdir(parents=True, exist_ok=True)
    result = run_harness(f"{engine}-gltf-cost", folder, spec, timeout=1800)
    costs: dict = {}
    for name, times in result["times"].items():
        index, variant = name.split("|")
        shader = result["shaders"][name]
        entry = {"ms": float(np.median(times)), "routes": result["routes"][name], "shader": shader}
        costs.setdefault(int(index), {})[variant] = {**entry, **glsl_counts(shader)}
    return costs


def net_ratio(costs: dict, variant: str) -> float:
    """One material's ``variant`` over the engine's own iridescence, each net of the draw without a film."""
    none, own = costs["none"]["ms"], costs["stock"]["ms"]
    return (costs[variant]["ms"] - none) / (own - none) if own > none else float("nan")


def glsl_counts(source: str) -> dict:
    """A WebGL2 fragment shader's SPIR-V counts: every loop marked [[unroll]] (as bench_runtime_cost.py
    marks them: a loop with a fixed trip count is counted as often as it runs), glslang -G (OpenGL SPIR-V:
    the engines' loose uniforms stay legal), then spirv_counts."""
    body = re.sub(r"\bfor\s*\(", "[[unroll]] for (", re.sub(r"^\s*#version .*$", "", source, flags=re.M))
    body = "#version 310 es\n#extension GL_EXT_control_flow_attributes : require\n" + body
    with tempfile.TemporaryDirectory() as tmp:
        frag, spv = Path(tmp) / "s.frag", Path(tmp) / "s.spv"
        frag.write_text(body)
        command = [str(PREFIX / "bin" / "glslang"), "-G", "--aml", "--amb", "-S", "frag", "-o", str(spv), str(frag)]
        out = subprocess.run(command, capture_output=True, text=True, env=_tool_env())
        if out.returncode:
            raise RuntimeError(out.stdout[-2000:] + out.stderr[-2000:])
        return spirv_counts(spv)


def spirv_counts(spv: Path) -> dict:
    """SPIR-V module ``spv`` after spirv-opt (loops marked unroll unrolled, -O): arithmetic weighted by
    components, transcendental calls and texture instructions (bench_runtime_cost._count) over every block,
    and the loops left (each counted once)."""
    opt = spv.with_name("o.spv")
    command = [str(PREFIX / "bin" / "spirv-opt"), "--loop-unroll", "-O", str(spv), "-o", str(opt)]
    subprocess.run(command, check=True, env=_tool_env())
    dis = [str(PREFIX / "bin" / "spirv-dis"), str(opt)]
    text = subprocess.run(dis, capture_output=True, text=True, env=_tool_env(), check=True).stdout
    components = {}
    for m in re.finditer(r"(%\w+) = OpType(Vector|Float|Int|Bool) ?(%\w+)? ?(\d+)?", text):
        components[m.group(1)] = int(m.group(4)) if m.group(2) == "Vector" else 1
    return {**_count(text.splitlines(), components), "loops": text.count("OpLoopMerge")}


def _tool_env() -> dict:
    return {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
