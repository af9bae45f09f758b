"""Benchmark B1 (the design brief's first benchmark): the kernel path against the numpy path, in one run.

    python bench/bench_b1.py [--points 1000] [--seed 1] [--json FILE] [--skip-numpy]

Grid: η1 = 1, η2 = 1.5; cos θ ∈ [0, 1] × 64, D ∈ [0, 4000] nm × 256,
η3 ∈ [1, 3] × 16, κ3 ∈ [0, 5] × 16 (4.19 M cells), Rec.709, CIE 1931 2°.
Each path bakes in its own subprocess (so peak RSS is its own) and reports
cells/s, wall time and peak RSS; the ratio between paths is the figure that
survives a noisy machine. Accuracy: the kernel's LUT, sampled through the
reference sampler at random in-range points, against the ground truth
(max and p99 ΔE00, max |ΔRGB|), plus the largest difference between the two
paths' LUTs.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

B1 = ["--eta2", "1.5", "--eta1", "1.0", "--cos-theta", "0:1:64", "--opd", "0:4000:256",
      "--eta3", "1:3:16", "--kappa3", "0:5:16", "--space", "rec709", "--observer", "cie1931"]


def child(backend: str, out: str, compute: str) -> None:
    """Bake B1 with one backend and print a JSON line (run in a fresh process)."""
    from lutbake.bake import bake
    from lutbake.plan import BakeSpec, parse_axis

    spec = BakeSpec(eta2=1.5, compute=compute, axes=(
        parse_axis("cos_theta", "0:1:64"), parse_axis("opd_nm", "0:4000:256"),
        parse_axis("eta3", "1:3:16"), parse_axis("kappa3", "0:5:16")))
    start = time.perf_counter()
    result = bake(spec, out, backend)
    wall = time.perf_counter() - start
    device = ""
    if result.backend == "opencl":
        from lutbake.integrate import OpenCLBackend
        device = OpenCLBackend(compute).device_name
    print(json.dumps({"backend": result.backend, "compute": compute, "device": device,
                      "cells": result.cells, "wall_s": wall, "cells_per_s": result.cells / wall,
                      "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))


def run_path(backend: str, out: Path, compute: str = "float64") -> dict:
    proc = subprocess.run([sys.executable, __file__, "--child", backend, "--out", str(out),
                           "--compute", compute], capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(f"{backend} bake failed: {proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def accuracy(lut_path: Path, n_points: int, seed: int) -> dict:
    from lutbake.colorimetry import delta_e00
    from lutbake.points import FilmPoints
    from lutbake.reference import reference_colour
    from lutbake.sample import Lut

    lut = Lut.load(lut_path)
    rng = np.random.default_rng(seed)
    params = [rng.uniform(a.lo, a.hi, n_points) for a in lut.axes]
    pts = FilmPoints.build(eta2=lut.eta2, cos_theta=params[0], opd_nm=params[1], eta3=params[2],
                           kappa3=params[3])
    truth = reference_colour(pts).values
    got = lut.sample(*params)
    de = delta_e00(got, truth)
    return {"points": n_points, "seed": seed, "de00_max": float(de.max()),
            "de00_p99": float(np.percentile(de, 99)), "de00_mean": float(de.mean()),
            "rgb_abs_max": float(np.abs(got - truth).max())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--out")
    ap.add_argument("--compute", default="float64")
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json")
    ap.add_argument("--skip-numpy", action="store_true")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out, args.compute)
        return
    from lutbake.sample import Lut

    with tempfile.TemporaryDirectory() as tmp:
        paths = {name: Path(tmp) / f"{name}.exr" for name in ("kernel", "kernel32", "numpy")}
        rows = {"kernel": run_path("opencl", paths["kernel"]),
                "kernel32": run_path("opencl", paths["kernel32"], "float32")}
        if not args.skip_numpy:
            rows["numpy"] = run_path("numpy", paths["numpy"])
        report = {"grid": "B1", "cells": rows["kernel"]["cells"], "paths": rows,
                  "accuracy_kernel_lut": accuracy(paths["kernel"], args.points, args.seed)}
        k = Lut.load(paths["kernel"]).image.astype(float)
        report["float32_vs_float64_rgb_max"] = float(np.abs(Lut.load(paths["kernel32"]).image - k).max())
        if "numpy" in rows:
            report["speedup_kernel_vs_numpy"] = rows["kernel"]["cells_per_s"] / rows["numpy"]["cells_per_s"]
            report["kernel_vs_numpy_rgb_max"] = float(np.abs(Lut.load(paths["numpy"]).image - k).max())
    text = json.dumps(report, indent=2)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")


if __name__ == "__main__":
    main()
