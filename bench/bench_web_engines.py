"""Accuracy and cost of lutbake's runtime table in Babylon.js, PlayCanvas and three.js's WebGPURenderer
(webgpu: the TSL node of engine/lutbake-tsl.js) against each engine's own iridescence, in one page per engine.

    .venv/bin/python bench/bench_web_engines.py          # accuracy
    .venv/bin/python bench/bench_web_engines.py cost     # cost
    .venv/bin/python bench/bench_web_engines.py static   # WebGPU's SPIR-V counts alone, no timing
    .venv/bin/python bench/bench_web_engines.py metals [--size 64]   # texture-driven metals' accuracy

Accuracy (tests/engines/test_web_engines.py's and test_webgpu_engine.py's runs: lit spheres, every pixel's
term and the parameters it used read back as float): per engine the largest difference from runtime.model at
every pixel, and ΔE00 against the ground truth (max and p99 over 1500 pixels) of lutbake's term and of the
engine's own.
Cost: a sphere lit by one directional light filling a 512² float target, per material with no iridescence,
the engine's own and lutbake's, interleaved rounds in one page (engine/babylon-page.js, playcanvas-page.js,
webgpu-page.js: the Cost functions); printed: median wall per draw of each, and the iridescence's share net
of the no-iridescence draw, lutbake's over the engine's own. For WebGPU also the static counts of each
draw's whole fragment shader, as three.js generated its WGSL: `naga` to SPIR-V, `spirv-opt -O`, counted as
bench_runtime_cost.py counts (arithmetic weighted by components, texture instructions; both sides of every
branch, so lutbake's dielectric and metal terms both); `static` prints these counts alone, without timing.
Metals: texture-driven metals of a `lutbake bake --gltf` output (tests/web_metals.py, the functions
tests/engines/test_web_gltf_metals.py runs) in Babylon.js and PlayCanvas, served by the bake and by the runtime
table: per material the largest |engine - lutbake's model| over the pixels and ΔE00 p99 / max against the
ground truth (120 pixels a material); --size: the render's side (every other pixel read; the test's is 64, the
default 32 keeps a run short on a loaded machine).
"""

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests")]
from bench_runtime_cost import PREFIX, _count  # noqa: E402  (the SPIR-V counting, beside this file)
from engine_harness import ENGINE  # noqa: E402  (the suite's helpers, found through the path above)
from runtime_contract import runtime_table_files  # noqa: E402
from web_engines import GLTF_PACKAGES, OWN_MODES, PACKAGES, engine_points, run_engine, truth_subset  # noqa: E402
from web_metals import ROUTES, bake_for_engines, metal_model, serve_metals, truth_errors  # noqa: E402

from lutbake.modes.runtime import runtime_colour  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402

COST_MATERIALS = [
    {"label": "soap on glass", "ior": 1.5, "iridescenceIOR": 1.33, "thickness": [300, 300]},
    {
        "label": "oxide on Cu",
        "ior": 1.5,
        "iridescenceIOR": 2.0,
        "thickness": [150, 150],
        "metal": {"eta": [0.367, 1.016, 1.246], "kappa": [3.121, 2.579, 2.452], "f0": [0.95, 0.64, 0.54]},
    },
]


ENGINES = [*sorted(PACKAGES), "webgpu"]


def wgsl_counts(wgsl: str) -> str:
    """A WGSL fragment shader's SPIR-V counts (naga, spirv-opt -O), or why there are none."""
    naga = shutil.which("naga")
    if naga is None:
        return "no WGSL counts (naga not found: cargo install naga-cli)"
    env = {**os.environ, "LD_LIBRARY_PATH": str(PREFIX / "lib")}
    with tempfile.TemporaryDirectory() as tmp:
        source, spv, opt = (Path(tmp) / n for n in ("s.wgsl", "s.spv", "o.spv"))
        source.write_text(wgsl)
        subprocess.run([naga, str(source), str(spv)], check=True, capture_output=True)
        subprocess.run([str(PREFIX / "bin" / "spirv-opt"), "-O", str(spv), "-o", str(opt)], check=True, env=env)
        text = subprocess.run(
            [str(PREFIX / "bin" / "spirv-dis"), str(opt)], capture_output=True, text=True, env=env, check=True
        ).stdout
    components = {}
    for m in re.finditer(r"(%\w+) = OpType(Vector|Float|Int|Bool) ?(%\w+)? ?(\d+)?", text):
        components[m.group(1)] = int(m.group(4)) if m.group(2) == "Vector" else 1
    counts = _count(text.splitlines(), components)
    return f"SPIR-V arithmetic {counts['arithmetic']}, texture instructions {counts['texture_instructions']}"


def _cost_run(engine: str, spec: dict) -> dict:
    """The ENGINE-cost page's result for ``spec`` (the runtime table added)."""
    path = runtime_table_files()
    spec = {"runtime": f"/{path.with_suffix('').relative_to(ROOT)}", "materials": COST_MATERIALS, **spec}
    with tempfile.TemporaryDirectory() as folder:
        job, out = Path(folder) / "spec.json", Path(folder) / "result.json"
        job.write_text(json.dumps(spec))
        command = ["node", str(ENGINE / "harness.mjs"), f"{engine}-cost", str(job), str(out)]
        subprocess.run(command, cwd=ROOT, check=True, capture_output=True, timeout=1200)
        return json.loads(out.read_text())


def _print_counts(result: dict, engine: str, material: dict) -> None:
    for mode in ("none", OWN_MODES[engine], "runtime"):
        wgsl = result["shaders"][f"{material['label']}|{mode}"]
        print(f"    {mode} fragment shader: {wgsl_counts(wgsl)}")


def cost() -> None:
    for engine in ENGINES:
        result = _cost_run(engine, {"size": 512, "rounds": 9, "draws": 3})
        times = {name: float(np.median(t)) for name, t in result["times"].items()}
        print(f"{engine}: median ms per 512² draw (load average {os.getloadavg()[0]:.1f})")
        for material in COST_MATERIALS:
            modes = ("none", OWN_MODES[engine], "runtime")
            none, own, lutbake = (times[f"{material['label']}|{mode}"] for mode in modes)
            ratio = (lutbake - none) / (own - none) if own > none else float("nan")
            walls = f"none {none:.1f}, own {own:.1f}, lutbake {lutbake:.1f}"
            print(f"  {material['label']}: {walls}; net lutbake/own {ratio:.2f}")
            if "shaders" in result:
                _print_counts(result, engine, material)


def static() -> None:
    """The WebGPU page's fragment shaders' SPIR-V counts without timing (one 16² draw of each, no rounds)."""
    result = _cost_run("webgpu", {"size": 16, "rounds": 0, "draws": 0})
    print("webgpu: static counts of each draw's whole fragment shader")
    for material in COST_MATERIALS:
        print(f"  {material['label']}:")
        _print_counts(result, "webgpu", material)


def accuracy() -> None:
    for engine in ENGINES:
        with tempfile.TemporaryDirectory() as folder:
            run = run_engine(engine, Path(folder))
        rgb, cos, d, eta2, eta3, kappa3, _ = engine_points(run, "runtime")
        model = runtime_colour(run["table"], cos, d, 1.0, eta2, eta3, kappa3)
        version = run["result"].get(engine, run["result"].get("three"))
        print(f"{engine} {version}: {len(rgb)} pixels, max |engine - runtime.model| {np.abs(rgb - model).max():.2e}")
        for mode, label in (("runtime", "lutbake runtime table"), (OWN_MODES[engine], f"{engine}'s own")):
            de = delta_e00(*truth_subset(run, mode))
            print(f"  {label}: ΔE00 max {de.max():.3f}, p99 {np.percentile(de, 99):.3f}")


def metals(size: int) -> None:
    (ROOT / "build").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "build") as folder:
        baked = bake_for_engines(Path(folder), sorted(GLTF_PACKAGES))
        for engine in sorted(GLTF_PACKAGES):
            for serve in sorted(ROUTES):
                result = serve_metals(engine, baked[engine], serve, Path(folder) / f"{engine}-{serve}", size)
                cells, manifest, out, table, rows = result
                records = {r["gltf_index"]: r for r in manifest["source"]["materials"]}
                load = f"load average {os.getloadavg()[0]:.1f}"
                print(f"{engine} served by {serve}, {size}² every other pixel ({load}):")
                for index, got in sorted(rows.items()):
                    record = records[index]
                    error = np.abs(got[:, :3] - metal_model(serve, record, manifest, out, table, got)).max()
                    de, _ = truth_errors(serve, record, manifest, out, table, got, index)
                    p99 = np.percentile(de, 99)
                    print(f"  material {index}: {len(got)} pixels, max |engine - model| {error:.1e};", end=" ")
                    print(f"ΔE00 p99 {p99:.3f}, max {de.max():.3f} ({len(de)} pixels)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("what", nargs="?", choices=["accuracy", "cost", "static", "metals"], default="accuracy")
    parser.add_argument("--size", type=int, default=32, help="metals: the render's side in pixels (test: 64)")
    args = parser.parse_args()
    runs = {"accuracy": accuracy, "cost": cost, "static": static, "metals": lambda: metals(args.size)}
    runs[args.what]()


if __name__ == "__main__":
    main()
