"""Accuracy and cost of lutbake's runtime table in Babylon.js and PlayCanvas against each engine's own
iridescence, in one page per engine.

    .venv/bin/python bench/bench_web_engines.py          # accuracy
    .venv/bin/python bench/bench_web_engines.py cost     # cost

Accuracy (tests/engines/test_web_engines.py's run: lit spheres, every pixel's term and the parameters it
used read back as float): per engine the largest difference from runtime.model at every pixel, and ΔE00
against the ground truth (max and p99 over 1500 pixels) of lutbake's term and of the engine's own.
Cost: a sphere lit by one directional light filling a 512² float target, per material with no iridescence,
the engine's own and lutbake's, interleaved rounds in one page (engine/babylon-page.js, playcanvas-page.js:
the Cost functions); printed: median wall per draw of each, and the iridescence's share net of the
no-iridescence draw, lutbake's over the engine's own.
"""

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests")]
from engine_harness import ENGINE  # noqa: E402  (the suite's helpers, found through the path above)
from runtime_contract import runtime_table_files  # noqa: E402
from web_engines import PACKAGES, engine_points, run_engine, truth_subset  # noqa: E402

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


def cost() -> None:
    path = runtime_table_files()
    spec = {"runtime": f"/{path.with_suffix('').relative_to(ROOT)}", "materials": COST_MATERIALS, "size": 512}
    spec.update(rounds=9, draws=3)
    for engine in sorted(PACKAGES):
        with tempfile.TemporaryDirectory() as folder:
            job, out = Path(folder) / "spec.json", Path(folder) / "result.json"
            job.write_text(json.dumps(spec))
            command = ["node", str(ENGINE / "harness.mjs"), f"{engine}-cost", str(job), str(out)]
            subprocess.run(command, cwd=ROOT, check=True, capture_output=True, timeout=1200)
            times = {name: float(np.median(t)) for name, t in json.loads(out.read_text())["times"].items()}
        print(f"{engine}: median ms per 512² draw (load average {os.getloadavg()[0]:.1f})")
        for material in COST_MATERIALS:
            none, own, lutbake = (times[f"{material['label']}|{mode}"] for mode in ("none", engine, "runtime"))
            ratio = (lutbake - none) / (own - none) if own > none else float("nan")
            walls = f"none {none:.1f}, own {own:.1f}, lutbake {lutbake:.1f}"
            print(f"  {material['label']}: {walls}; net lutbake/own {ratio:.2f}")


def accuracy() -> None:
    for engine in sorted(PACKAGES):
        with tempfile.TemporaryDirectory() as folder:
            run = run_engine(engine, Path(folder))
        rgb, cos, d, eta2, eta3, kappa3, _ = engine_points(run, "runtime")
        model = runtime_colour(run["table"], cos, d, 1.0, eta2, eta3, kappa3)
        print(
            f"{engine} {run['result'].get(engine)}: {len(rgb)} pixels, max |engine - runtime.model| "
            f"{np.abs(rgb - model).max():.2e}"
        )
        for mode, label in (("runtime", "lutbake runtime table"), (engine, f"{engine}'s own")):
            de = delta_e00(*truth_subset(run, mode))
            print(f"  {label}: ΔE00 max {de.max():.3f}, p99 {np.percentile(de, 99):.3f}")


if __name__ == "__main__":
    cost() if sys.argv[1:] == ["cost"] else accuracy()
