"""The exact mode's searched maximum ΔE00: over each default LUT's domain, and near the dielectric corner.

1. Per default LUT (luts/, baked when missing): the `lutbake-exact-mode` row's searched max as `lutbake report`
   finds it (measure.search_max: 1,000 held-out points at seed 0, 20,000 evaluations), where, how found.
2. The corner's neighbourhood alone, cos θ1 ≤ 0.02, D ≤ 20 nm, η3 − η1 ≤ 1e-3, κ3 ≤ 1e-3 (tests/exact_cases.py
   corner_search, 3,000 evaluations) for η2 1.33, 1.5, 2.0 and 3.0; and the share of its random points where
   the 64-term cap binds (the closed-form tail's share of pixels).
No timings: accuracy only (numpy float64 evaluation of the include's math; three.js returns it to 4.5e-6,
tests/engines/test_exact_engine.py).

Rerun: python bench/bench_exact_corner.py   (writes bench/exact-corner-result.json)
"""

import json
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT), str(ROOT / "tests"), str(ROOT / "docs")]

from exact_cases import CORNER_SPAN, corner_search  # noqa: E402
from make_accuracy import bake_default_luts  # noqa: E402

from lutbake.lut.sample import Lut  # noqa: E402
from lutbake.modes.exact import exact_colour, exact_mode_rgb, stored_table  # noqa: E402
from lutbake.quality import measure  # noqa: E402


def lut_row(path: Path) -> dict:
    lut = Lut.load(path)
    space, observer = lut.meta["space"], lut.meta["observer"]
    pts = measure.held_out_points(lut.axes, lut.eta1, lut.eta2, observer, space, 1000, 0)

    def read(stack):
        return exact_mode_rgb(stack, space, observer)

    held = measure.score("lutbake-exact-mode", read(pts.stack), pts, space, observer, 0.0)
    found = measure.search_max(read, lut, pts, held.de00, measure.proxy_truth(lut), measure.SEARCH_BUDGET, 0)
    return {k: found[k] for k in ("de00_max", "cos_theta", "opd_nm", "eta3", "kappa3", "found_by", "held_out_max")}


def capped_share(eta2: float, n: int = 4000) -> float:
    u = np.random.default_rng(0).uniform(0.0, 1.0, (n, 4)) ** 3 * CORNER_SPAN
    result = exact_colour(stored_table(), u[:, 0], u[:, 1] / (2.0 * eta2), 1.0, eta2, 1.0 + u[:, 2], u[:, 3])
    return float((result.terms == 64).mean())


def main():
    bake_default_luts()
    luts = {p.stem: lut_row(p) for p in sorted((ROOT / "luts").glob("lutbake-eta2-*.exr"))}
    corner = {}
    for eta2 in (1.33, 1.5, 2.0, 3.0):
        value, where, how = corner_search(stored_table(), eta2, budget=3000)
        corner[str(eta2)] = {
            "de00_max": value,
            "cos_theta": where[0],
            "opd_nm": where[1],
            "eta3_minus_eta1": where[2],
            "kappa3": where[3],
            "found_by": how,
            "capped_share": capped_share(eta2),
        }
    out = {"luts": luts, "corner": corner, "load_average": os.getloadavg()[0]}
    (ROOT / "bench" / "exact-corner-result.json").write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
