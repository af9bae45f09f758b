"""Series vs direct kernel on one band of B1, interleaved in one process (robust to a busy machine).

    python bench/bench_series_band.py [--rows 256] [--reps 3]

Times OpenCLBackend.bake_rows for the first ``rows`` image rows of B1 (κ3 = 0
tiles; 1024 texels per row) with the series kernel and with the direct
quadrature alone, alternating, after one warm-up each (program build and
PoCL's first-launch compilation excluded). PYOPENCL_CTX picks the runtime.
Prints the median seconds of each and their ratio as JSON.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=256)
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    from bench_b1 import B1_AXES, _spec

    from lutbake.integrate.opencl import OpenCLBackend

    spec = _spec(1.5, B1_AXES)
    paths = {name: OpenCLBackend("float64", name) for name in ("series", "direct")}
    times = {name: [] for name in paths}
    for backend in paths.values():
        backend.bake_rows(spec, 0, args.rows)
    for _ in range(args.reps):
        for name, backend in paths.items():
            start = time.perf_counter()
            backend.bake_rows(spec, 0, args.rows)
            times[name].append(time.perf_counter() - start)
    median = {name: float(np.median(t)) for name, t in times.items()}
    print(
        json.dumps(
            {
                "device": paths["series"].device,
                "texels": args.rows * spec.image_size[0],
                "seconds": median,
                "direct_over_series": median["direct"] / median["series"],
            }
        )
    )


if __name__ == "__main__":
    main()
