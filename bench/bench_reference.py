"""The ground truth's cost (lutbake.spectral.reference.reference_colour) by chunk size and thread count.

    python bench/bench_reference.py [--points 2304] [--runs 3] [--json FILE]

One run, interleaved: the former layout (1M (point, node) pairs per chunk, one thread), today's chunks on one
thread, and today's chunks on every core this process may use, at report-like points (uniform over a
default LUT's domain: cos θ1 0.01–1, D 0–3000 nm, η3 1–3, κ3 0–3, film η2 1.5). Reports the median wall,
CPU time over wall (are the cores busy?), the peak of numpy's allocations and the largest difference from
the former layout (the chunks change only the order of the rule's sums: a few ulps).
"""

import argparse
import json
import os
import statistics
import time
import tracemalloc
from pathlib import Path

import numpy as np

from lutbake.io.cores import usable_cores
from lutbake.physics.points import FilmPoints
from lutbake.spectral import reference

LAYOUTS = {  # name: (pairs per chunk, threads)
    "1M pairs, 1 thread (before)": (1_000_000, 1),
    "64k pairs, 1 thread": (65_536, 1),
    f"64k pairs, {usable_cores()} threads (default)": (65_536, None),
}


def points(n: int) -> FilmPoints:
    rng = np.random.default_rng(0)
    return FilmPoints.build(
        eta1=1.0,
        eta2=1.5,
        cos_theta=rng.uniform(0.01, 1.0, n),
        opd_nm=rng.uniform(0.0, 3000.0, n),
        eta3=rng.uniform(1.0, 3.0, n),
        kappa3=rng.uniform(0.0, 3.0, n),
    )


def measure(pts: FilmPoints, chunk: int, workers: int | None) -> tuple[float, float, int, np.ndarray]:
    reference._CELLS_PER_CHUNK = chunk  # the layout under test (a module constant, set for this bench only)
    tracemalloc.start()
    wall, cpu = time.perf_counter(), time.process_time()
    rgb = reference.reference_colour(pts, workers=workers).values
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return wall, cpu, peak, rgb


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2304)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--json", type=Path)
    opts = parser.parse_args()
    pts = points(opts.points)
    runs: dict[str, list[tuple[float, float, int, np.ndarray]]] = {name: [] for name in LAYOUTS}
    for _ in range(opts.runs):
        for name, (chunk, workers) in LAYOUTS.items():
            runs[name].append(measure(pts, chunk, workers))
    before = runs[next(iter(LAYOUTS))][0][3]
    rows = []
    for name, results in runs.items():
        wall = statistics.median(r[0] for r in results)
        rows.append(
            {
                "layout": name,
                "wall_s": wall,
                "cpu_per_wall": statistics.median(r[1] / r[0] for r in results),
                "peak_numpy_mib": max(r[2] for r in results) / 2**20,
                "max_abs_diff_vs_before": float(np.max(np.abs(results[0][3] - before))),
            }
        )
    for row in rows:
        row["speedup_vs_before"] = rows[0]["wall_s"] / row["wall_s"]
        print(
            f"{row['layout']:<32} {row['wall_s']:7.2f} s  CPU/wall {row['cpu_per_wall']:.2f}  "
            f"peak {row['peak_numpy_mib']:6.1f} MiB  {row['speedup_vs_before']:.2f}x  "
            f"|Δ| {row['max_abs_diff_vs_before']:.1e}"
        )
    result = {"points": opts.points, "runs": opts.runs, "load_average": os.getloadavg(), "rows": rows}
    if opts.json:
        opts.json.write_text(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
