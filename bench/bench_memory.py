"""Peak memory of a bake against the memory model (lutbake/grid/memory.py, BakeSpec.memory), shape by shape.

    python bench/bench_memory.py [--shapes NAME ...] [--devices KEY ...] [--json FILE]

Each shape bakes in its own process (peak RSS is that process's own: VmHWM) and reports the
wall time, cells/s, the file's size, the measured peak, the model's estimate by item as the bake's
last check has it (the runtime's resident memory measured, the plan's outcome known) and their ratio,
and the estimate the bake checks before any work (constants and bounds from the shape alone).
The shapes stress one term of the model each: the bands (B1, a default metal LUT), the (cos θ, D)
pairs, the (cos θ, η3, κ3) columns, the numpy path's chunks, a grid of 63 M cells (and, asked for by
name, one of 513 M: minutes); tests/grid/test_memory.py runs a few of them small, on every runtime.
--devices bakes each shape on each device named (`lutbake devices`; default: lutbake's default device).
"""

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

# name: (shape cos θ × D × η3 × κ3, largest D in nm, backend, precision)
SHAPES = {
    "b1": ((64, 256, 16, 16), 4000.0, "opencl", "float"),
    "metal": ((32, 192, 18, 21), 3000.0, "opencl", "half"),
    "pairs": ((1000, 1000, 2, 2), 100.0, "opencl", "half"),
    "columns": ((32, 8, 150, 150), 100.0, "opencl", "half"),
    "numpy": ((16, 32, 8, 8), 1000.0, "numpy", "half"),
    "63M": ((64, 256, 62, 62), 100.0, "opencl", "half"),
    "513M": ((64, 256, 177, 177), 100.0, "opencl", "half"),  # minutes; not in the default run
    # the small ones tests/grid/test_memory.py bakes
    "small-bands": ((64, 256, 8, 8), 4000.0, "opencl", "float"),
    "small-pairs": ((600, 600, 2, 2), 100.0, "opencl", "half"),
    "small-columns": ((32, 8, 120, 120), 100.0, "opencl", "half"),
    "small-numpy": ((8, 16, 4, 4), 1000.0, "numpy", "half"),
}


def spec_of(shape, opd_max, precision):
    from lutbake.grid.spec import Axis, BakeSpec

    n_cos, n_opd, n_eta3, n_kappa3 = shape
    return BakeSpec(
        eta2=1.5,
        precision=precision,
        axes=(
            Axis("cos_theta", 0.0, 1.0, n_cos, "sqrt"),
            Axis("opd_nm", 0.0, opd_max, n_opd),
            Axis("eta3", 1.0, 3.0, n_eta3),
            Axis("kappa3", 0.0, 5.0, n_kappa3, "sqrt"),
        ),
    )


def child(name: str, out: str, device=None) -> None:
    """Bake ``name`` and print one JSON line (runs in its own process): the peak against the model with
    the runtime's resident memory and the plan as the bake's last check before the bands has them, and
    the estimate before any work."""
    from lutbake.integrate.opencl import backend as make_backend
    from lutbake.lut.bake import bake, resident_bytes

    shape, opd_max, backend, precision = SHAPES[name]
    spec = spec_of(shape, opd_max, precision)
    integrator = make_backend(backend, device=device)  # what write_lut does first: the runtime up, measured
    runtime = resident_bytes()
    start = time.perf_counter()
    result = bake(spec, out, backend, memory_limit_gib=64.0, device=device)
    wall = time.perf_counter() - start
    model = spec.memory(backend, runtime_bytes=runtime, plan=integrator.series_plan(spec))
    peak = resident_bytes(peak=True)
    print(
        json.dumps(
            {
                "name": name,
                "shape": list(shape),
                "cells": spec.cells,
                "backend": result.backend,
                "device": result.device,
                "wall_s": wall,
                "cells_per_s": spec.cells / wall,
                "file_mib": Path(out).stat().st_size / 2**20,
                "peak_rss_mib": peak / 2**20,
                "runtime_mib": runtime / 2**20,
                "estimate_mib": model["peak"] / 2**20,
                "estimate_over_measured": model["peak"] / peak,
                "estimate_before_work_mib": spec.memory(backend)["peak"] / 2**20,
                "model_mib": {k: v / 2**20 for k, v in model.items()},
            }
        )
    )


def measure(name: str, folder: Path, device: str = "") -> dict:
    proc = subprocess.run(
        [sys.executable, __file__, "--child", name, "--out", str(folder / f"{name}.exr"), "--device", device],
        capture_output=True,
        text=True,
    )
    if proc.returncode:
        raise SystemExit(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main():
    import tempfile

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--out")
    ap.add_argument("--shapes", nargs="+", default=[name for name in SHAPES if name != "513M"])
    ap.add_argument("--device", default="")  # the child's
    ap.add_argument("--devices", nargs="+", default=[""])
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out, args.device or None)
        return
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for device in args.devices:
            for name in args.shapes:
                rows.append(measure(name, Path(tmp), device))
            print(json.dumps(rows[-1]), flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
