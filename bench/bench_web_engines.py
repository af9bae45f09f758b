"""Accuracy of lutbake's runtime table in Babylon.js and PlayCanvas against each engine's own iridescence,
in one page per engine (tests/engines/test_web_engines.py's run: lit spheres, every pixel's term and the
parameters it used read back as float).

    .venv/bin/python bench/bench_web_engines.py

Prints per engine: the largest difference from runtime.model at every pixel, and ΔE00 against the ground
truth (max and p99 over 1500 pixels) of lutbake's term and of the engine's own.
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT / "tests" / "engines"), str(ROOT / "tests" / "modes"), str(ROOT / "tests")]
from test_web_engines import PACKAGES, _points, _truth_subset, run_engine  # noqa: E402

from lutbake.modes.runtime import runtime_colour  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402


def main() -> None:
    for engine in sorted(PACKAGES):
        with tempfile.TemporaryDirectory() as folder:
            run = run_engine(engine, Path(folder))
        rgb, cos, d, eta2, eta3, kappa3, _ = _points(run, "runtime")
        model = runtime_colour(run["table"], cos, d, 1.0, eta2, eta3, kappa3)
        print(
            f"{engine} {run['result'].get(engine)}: {len(rgb)} pixels, max |engine - runtime.model| "
            f"{np.abs(rgb - model).max():.2e}"
        )
        for mode, label in (("runtime", "lutbake runtime table"), (engine, f"{engine}'s own")):
            de = delta_e00(*_truth_subset(run, mode))
            print(f"  {label}: ΔE00 max {de.max():.3f}, p99 {np.percentile(de, 99):.3f}")


if __name__ == "__main__":
    main()
