"""Accuracy and cost of lutbake's runtime table in Babylon.js, PlayCanvas and three.js's WebGPURenderer
(webgpu: the TSL node of engine/lutbake-tsl.js) against each engine's own iridescence, in one page per engine.

    .venv/bin/python bench/bench_web_engines.py          # accuracy
    .venv/bin/python bench/bench_web_engines.py cost     # cost
    .venv/bin/python bench/bench_web_engines.py static   # WebGPU's SPIR-V counts alone, no timing
    .venv/bin/python bench/bench_web_engines.py metals [--size 64]   # texture-driven metals' accuracy
    .venv/bin/python bench/bench_web_engines.py gltf-cost [--size 256] [--rounds 9]   # the glTF hooks' cost

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
glTF cost: the glTF hooks of Babylon.js and PlayCanvas against each engine's own iridescence in one page: the
metals' asset loaded without a film, stock, served by the bake and by the runtime table (tests/web_gltf_cost.py,
the functions tests/engines/test_web_gltf_metals.py runs); per material and variant the median wall per draw
of a --size² target (default 128) over --rounds (default 5), its ratio to the stock draw's and net of the draw
without a film, and the whole fragment shader's SPIR-V counts (glslang, as bench_runtime_cost.py counts).
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests")]
from engine_harness import ENGINE  # noqa: E402  (the suite's helpers, found through the path above)
from runtime_contract import runtime_table_files  # noqa: E402
from web_engines import GLTF_PACKAGES, OWN_MODES, PACKAGES, engine_points, run_engine, truth_subset  # noqa: E402
from web_gltf_cost import VARIANTS, hook_costs, net_ratio, spirv_counts  # noqa: E402
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
    with tempfile.TemporaryDirectory() as tmp:
        source, spv = Path(tmp) / "s.wgsl", Path(tmp) / "s.spv"
        source.write_text(wgsl)
        subprocess.run([naga, str(source), str(spv)], check=True, capture_output=True)
        counts = spirv_counts(spv)
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


def gltf_cost(size: int, rounds: int) -> None:
    """The glTF hooks' cost against each engine's own iridescence (tests/web_gltf_cost.py), the asset baked
    once by the CLI into a temporary folder under build/ (both engines load it, thickness textures included)."""
    (ROOT / "build").mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory(dir=ROOT / "build") as folder:
        baked = bake_for_engines(Path(folder), sorted(GLTF_PACKAGES))
        for engine in sorted(GLTF_PACKAGES):
            before = os.getloadavg()[0]
            costs = hook_costs(engine, baked[engine], Path(folder) / f"{engine}-cost", size, rounds, draws=3)
            load = f"load average {before:.1f}-{os.getloadavg()[0]:.1f}"
            print(f"{engine}: median ms per {size}² draw over {rounds} rounds ({load}); x own: over the stock draw,")
            print("  net: each net of the draw without a film; SPIR-V of the whole fragment shader")
            for index, variants in sorted(costs.items()):
                print(f"  material {index}:")
                for variant in VARIANTS:
                    print(f"    {variant:8} {_cost_line(engine, variants, variant)}")


def _cost_line(engine: str, variants: dict, variant: str) -> str:
    cost = variants[variant]
    ratios = f"x own {cost['ms'] / variants['stock']['ms']:.2f}, net {net_ratio(variants, variant):.2f}; "
    served = {"none": "no film", "stock": f"{engine}'s own"}.get(variant)
    parts = served or ", ".join(f"{part} {route}" for part, route in cost["routes"].items())
    counts = f"arithmetic {cost['arithmetic']}, transcendental {cost['transcendental']}"
    reads = f"texture instructions {cost['texture_instructions']}" + (
        f", loops left {cost['loops']}" if cost["loops"] else ""
    )
    return f"{cost['ms']:7.2f} ms; {'' if served else ratios}{counts}, {reads} ({parts})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    modes = ["accuracy", "cost", "static", "metals", "gltf-cost"]
    parser.add_argument("what", nargs="?", choices=modes, default="accuracy")
    parser.add_argument(
        "--size",
        type=int,
        help="metals: the render's side in pixels (default 32, test: 64); gltf-cost: the target's (default 128)",
    )
    parser.add_argument("--rounds", type=int, default=5, help="gltf-cost: timed rounds (default 5)")
    args = parser.parse_args()
    runs = {
        "accuracy": accuracy,
        "cost": cost,
        "static": static,
        "metals": lambda: metals(args.size or 32),
        "gltf-cost": lambda: gltf_cost(args.size or 128, args.rounds),
    }
    runs[args.what]()


if __name__ == "__main__":
    main()
