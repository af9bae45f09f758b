"""Accuracy and cost of the bake's spectral rule against --samples-per-cycle.

    python bench/bench_spectral_rule.py [--texels 600] [--seed 3] [--json FILE]

Random texels (η2 1.2–2.5, cos θ = u², D ≤ 4 µm, η3 1–3, κ3 ≤ 5) are integrated
with the per-texel ladder rules (numpy path, same rules as the kernel) at each
setting and compared with the converged ground truth: max and p99 |ΔRGB|, and the
mean spectral nodes per texel (the kernel's cost is proportional to it).
"""

import argparse
import json
from pathlib import Path

import numpy as np

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.numpy_path import NumpyBackend
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--texels", type=int, default=600)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--json")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    n = args.texels
    eta2 = rng.uniform(1.2, 2.5, n)
    cols = {
        "cos_theta": rng.uniform(0, 1, n) ** 2,
        "opd_nm": rng.uniform(0, 4000, n),
        "eta3": rng.uniform(1, 3, n),
        "kappa3": rng.uniform(0, 5, n),
    }
    truth = reference_colour(FilmPoints.build(eta2=eta2, **cols)).values
    rows = []
    for spc in (1.0, 2.0, 3.0, 4.0, 6.0):
        fast, nodes = np.empty((n, 3)), np.empty(n)
        for i in range(n):  # each texel has its own η2 here, hence its own spec
            axes = (Axis("cos_theta", 0, 1, 2), Axis("opd_nm", 0, 1, 2), Axis("eta3", 1, 2, 2), Axis("kappa3", 0, 1, 2))
            spec = BakeSpec(eta2=float(eta2[i]), axes=axes, samples_per_cycle=spc)
            p = [np.array([cols[k][i]]) for k in ("cos_theta", "opd_nm", "eta3", "kappa3")]
            fast[i] = NumpyBackend().evaluate(spec, spec.texel_stacks(p))[0]
            nodes[i] = spec.ladder.counts[int(spec.cell_levels(*p)[0])]
        err = np.abs(fast - truth).max(axis=1)
        rows.append(
            {
                "samples_per_cycle": spc,
                "rgb_abs_max": float(err.max()),
                "rgb_abs_p99": float(np.percentile(err, 99)),
                "mean_nodes": float(nodes.mean()),
            }
        )
        print(json.dumps(rows[-1]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
