"""Peak memory of a bake does not grow with the grid (bounded, band by band).

    python bench/bench_memory.py [--cells 8e6 64e6 512e6] [--json FILE]

Bakes grids of increasing size — thin films (D ≤ 100 nm: 16 spectral nodes per
texel, so the big one finishes in minutes) stored as half — each in its own
process, and reports wall time, cells/s, file size and peak RSS. Peak RSS should
stay flat: the kernel works on bands of ~1 M cells and the EXR is streamed.
"""

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def child(cells: float, out: str) -> None:
    from lutbake.bake import bake
    from lutbake.plan import Axis, BakeSpec

    n_side = round((cells / (64 * 256)) ** 0.5)
    axes = (Axis("cos_theta", 0.0, 1.0, 64, "sqrt"), Axis("opd_nm", 0.0, 100.0, 256),
            Axis("eta3", 1.0, 3.0, n_side), Axis("kappa3", 0.0, 5.0, n_side, "sqrt"))
    spec = BakeSpec(eta2=1.5, axes=axes, precision="half")
    start = time.perf_counter()
    result = bake(spec, out)
    wall = time.perf_counter() - start
    print(json.dumps({"cells": spec.cells, "shape": list(spec.shape), "backend": result.backend, "wall_s": wall,
                      "cells_per_s": spec.cells / wall, "file_mib": Path(out).stat().st_size / 2**20,
                      "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--child", type=float)
    ap.add_argument("--out")
    ap.add_argument("--cells", type=float, nargs="+", default=[8e6, 64e6, 512e6])
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out)
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for cells in args.cells:
            out = Path(tmp) / "big.exr"
            proc = subprocess.run([sys.executable, __file__, "--child", str(cells), "--out", str(out)],
                                  capture_output=True, text=True)
            if proc.returncode:
                raise SystemExit(proc.stderr)
            rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
            out.unlink()
            print(json.dumps(rows[-1]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
