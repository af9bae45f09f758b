"""Accuracy and cost of lutbake's runtime table in Babylon.js, PlayCanvas and three.js's WebGPURenderer
(webgpu: the TSL node of engine/lutbake-tsl.js) against each engine's own iridescence, in one page per engine.

    .venv/bin/python bench/bench_web_engines.py          # accuracy
    .venv/bin/python bench/bench_web_engines.py cost     # cost

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
branch, so lutbake's dielectric and metal terms both).
"""

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
from web_engines import OWN_MODES, PACKAGES, engine_points, run_engine, truth_subset  # noqa: E402

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


def cost() -> None:
    path = runtime_table_files()
    spec = {"runtime": f"/{path.with_suffix('').relative_to(ROOT)}", "materials": COST_MATERIALS, "size": 512}
    spec.update(rounds=9, draws=3)
    for engine in ENGINES:
        with tempfile.TemporaryDirectory() as folder:
            job, out = Path(folder) / "spec.json", Path(folder) / "result.json"
            job.write_text(json.dumps(spec))
            command = ["node", str(ENGINE / "harness.mjs"), f"{engine}-cost", str(job), str(out)]
            subprocess.run(command, cwd=ROOT, check=True, capture_output=True, timeout=1200)
            result = json.loads(out.read_text())
        times = {name: float(np.median(t)) for name, t in result["times"].items()}
        print(f"{engine}: median ms per 512² draw (load average {os.getloadavg()[0]:.1f})")
        for material in COST_MATERIALS:
            modes = ("none", OWN_MODES[engine], "runtime")
            none, own, lutbake = (times[f"{material['label']}|{mode}"] for mode in modes)
            ratio = (lutbake - none) / (own - none) if own > none else float("nan")
            walls = f"none {none:.1f}, own {own:.1f}, lutbake {lutbake:.1f}"
            print(f"  {material['label']}: {walls}; net lutbake/own {ratio:.2f}")
            for mode in modes if "shaders" in result else ():
                wgsl = result["shaders"][f"{material['label']}|{mode}"]
                print(f"    {mode} fragment shader: {wgsl_counts(wgsl)}")


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


if __name__ == "__main__":
    cost() if sys.argv[1:] == ["cost"] else accuracy()
