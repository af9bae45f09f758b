"""Benchmark B1 (docs/spectral.md): `lutbake bake` of the B1 grid on every OpenCL runtime, the direct
quadrature alone, and an independent numpy integration at 2 nm, in one run.

    python bench/bench_b1.py [--points 1000] [--seed 1] [--json FILE] [--skip-numpy] [--pool-runs 3]

Grid: η1 = 1, η2 = 1.5; cos θ ∈ [0, 1] × 64, D ∈ [0, 4000] nm × 256,
η3 ∈ [1, 3] × 16, κ3 ∈ [0, 5] × 16 (4.19 M cells), Rec.709, CIE 1931 2°.
Each path runs in its own process: the bakes through the CLI (`lutbake bake --json … --device KEY`,
float64 and --compute float32) and, for reference, the direct quadrature on every texel (bake() with
integrator='direct'; no CLI flag). Each row gives the bake's wall time, the whole process's (interpreter
start and imports included: what `lutbake bake` costs), cells/s of both, the process's CPU time over its
wall (``process_cpu_per_wall``: 2 on 2 cores when both are busy throughout), peak RSS (VmHWM), the
texels per path (series, closed form, direct) from the LUT's header, and where the time went: the
process's start (``startup_s``: interpreter, imports) and the bake's stages (``stages``: compile, plan,
device, write, other, and the bake's own CPU over wall; lutbake/lut/pipeline.py). ``exr_pool``: the
default device's float64 bake (bake()) with OpenEXR's compression pool sized to the cores against no pool
(exr_threads=0), run in turn (``--pool-runs`` pairs), the ratio of their walls taken pair by pair; the
bytes are the same. The numpy path evaluates
optics.film_reflectance at 360, 362, …, 830 nm with trapezoid weights: a straightforward independent
integration. Accuracy: the baked texels (not interpolated points) at random grid nodes and on a stiff
grid (thick films near grazing incidence over metals and over a base that reflects totally), against the
ground truth (lutbake/spectral/reference.py).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

B1_AXES = ("0:1:64", "0:4000:256", "1:3:16", "0:5:16")
STIFF = {"eta2": 2.5, "axes": ("0.01:0.1:4", "15000:20000:4", "1:1.5:4", "0:20:4")}
_FLAGS = ("--cos-theta", "--opd", "--eta3", "--kappa3")


def _spec(eta2, axes, compute="float64"):
    from lutbake.grid.spec import AXIS_NAMES, BakeSpec, parse_axis

    return BakeSpec(eta2=eta2, compute=compute, axes=tuple(parse_axis(n, a) for n, a in zip(AXIS_NAMES, axes)))


def numpy_2nm(spec, out: str, rows: int = None) -> None:
    """RGB of every texel (of the first ``rows`` image rows) by R at 2 nm steps and trapezoid weights;
    saved as .npy."""
    from lutbake.physics.colorimetry import colorimetry
    from lutbake.physics.optics import film_reflectance

    lam = np.arange(360.0, 830.1, 2.0)
    quad = np.full(lam.size, 2.0)
    quad[[0, -1]] = 1.0
    weights = colorimetry(spec.observer, spec.space).sensitivity(lam) * quad
    height = rows or spec.image_size[1]
    chunks = [(y0, min(y1, height)) for y0, y1 in spec.row_chunks(1 << 14) if y0 < height]
    image = np.concatenate([_rows_2nm(spec, y0, y1, lam, weights, film_reflectance) for y0, y1 in chunks])
    np.save(out, image.reshape(height, -1, 3))


def _rows_2nm(spec, y0, y1, lam, weights, film_reflectance):
    stacks = spec.texel_stacks(np.ravel(p) for p in spec.cell_params(y0, y1))
    refl = film_reflectance(stacks.as_column(), lam)[2]
    return refl @ weights.T


def cli_argv(eta2, axes, compute, device, out) -> list:
    """`lutbake bake` for one LUT of the grid."""
    flags = [token for flag, axis in zip(_FLAGS, axes) for token in (flag, axis)]
    return [
        "bake",
        "--quiet",
        "--json",
        "--eta2",
        str(eta2),
        *flags,
        "--compute",
        compute,
        "--backend",
        "opencl",
        "--device",
        device,
        "--out",
        out,
    ]


def child(path: str, out: str, compute: str, grid: str, device: str) -> None:
    """Bake one grid with one path and print a JSON line (run in a fresh process). Paths: 'numpy-2nm',
    'series' (the CLI), 'direct' (bake()), 'pool' and 'no-pool' (bake() with OpenEXR's pool, and without)."""
    from lutbake.lut.bake import resident_bytes

    eta2, axes = (1.5, B1_AXES) if grid == "b1" else (STIFF["eta2"], STIFF["axes"])
    spec = _spec(eta2, axes, compute)
    start = time.perf_counter()
    row = {"path": path, "compute": compute}
    if path == "numpy-2nm":
        numpy_2nm(spec, out)
    elif path == "series":
        row.update(_cli_bake(cli_argv(eta2, axes, compute, device, out)))
    else:
        from lutbake.lut.bake import bake
        from lutbake.lut.sets import summary

        integrator = "direct" if path == "direct" else "series"
        result = bake(
            spec, out, "opencl", integrator=integrator, device=device, exr_threads=0 if path == "no-pool" else None
        )
        row["stages"] = summary(result)["stages"]
    if path != "numpy-2nm":
        sidecar = json.loads(Path(out).with_suffix(".json").read_text())
        row["device"] = sidecar["baked_on"]["device"]
        row["integrator"] = sidecar["integrator"]
    wall = time.perf_counter() - start
    row.update(
        cells=spec.cells, wall_s=wall, cells_per_s=spec.cells / wall, peak_rss_mib=resident_bytes(peak=True) / 2**20
    )
    print(json.dumps(row))


def cli_json(argv: list) -> dict:
    """`lutbake ARGV` (a bake with --json) in this process: what it prints (each LUT's stages; the library
    is imported by then: the row's ``startup_s`` holds the imports)."""
    import contextlib
    import io

    from lutbake.cli import main

    sys.argv, printed = ["lutbake", *argv], io.StringIO()
    try:
        with contextlib.redirect_stdout(printed):
            main()
    except SystemExit as exc:
        if exc.code:
            raise
    return json.loads(printed.getvalue())


def _cli_bake(argv: list) -> dict:
    return {"stages": cli_json(argv)["luts"][0]["stages"]}


def run_child(script: str, *args: str, checkout: Path | None = None) -> dict:
    """``script --child ARGS`` in a fresh process (``checkout``'s lutbake/ first on PYTHONPATH where given:
    another version, e.g. `git worktree add DIR main`): the JSON line it prints, with the process's wall
    time, its CPU time over that wall and cells per second of it."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    env = None
    if checkout is not None:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run([sys.executable, script, "--child", *args], capture_output=True, text=True, env=env)
    if proc.returncode:
        raise SystemExit(f"{' '.join(args)} failed: {proc.stderr.strip()}")
    row = json.loads(proc.stdout.strip().splitlines()[-1])
    row["process_wall_s"] = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    row["process_cpu_per_wall"] = cpu / row["process_wall_s"]
    row["startup_s"] = row["process_wall_s"] - row["wall_s"]  # the interpreter, imports, the child's own set-up
    row["process_cells_per_s"] = row["cells"] / row["process_wall_s"]
    return row


def run_path(path: str, out: Path, compute: str = "float64", device: str = "", grid: str = "b1") -> dict:
    return run_child(__file__, path, "--out", str(out), "--compute", compute, "--grid", grid, "--device", device)


def exr_pool(tmp: Path, device: str, runs: int) -> dict:
    """The float64 bake with OpenEXR's pool ('pool') and without ('no-pool'), in turn, ``runs`` pairs: each
    side's median wall and CPU over wall, and the median of no-pool's wall over pool's, pair by pair."""
    pairs = [
        [run_path(path, tmp / f"{path}.exr", "float64", device) for path in ("pool", "no-pool")] for _ in range(runs)
    ]
    same = (tmp / "pool.exr").read_bytes() == (tmp / "no-pool.exr").read_bytes()
    out = {"device": device, "runs": runs, "same_bytes": same}
    for i, path in enumerate(("pool", "no-pool")):
        rows = [pair[i] for pair in pairs]
        out[path] = {
            "wall_s": statistics.median(r["wall_s"] for r in rows),
            "write_s": statistics.median(r["stages"]["write_s"] for r in rows),
            "bake_cpu_per_wall": statistics.median(r["stages"]["cpu_per_wall"] for r in rows),
        }
    out["no_pool_over_pool_wall"] = statistics.median(b["wall_s"] / a["wall_s"] for a, b in pairs)
    return out


def devices() -> list:
    """Keys of the OpenCL devices that build the kernel (lutbake devices), the default first."""
    from lutbake.errors import OpenCLUnavailable
    from lutbake.integrate.devices import device_key, opencl_devices
    from lutbake.integrate.program import built_program

    return [device_key(d) for d in opencl_devices() if not isinstance(built_program(d, "float64"), OpenCLUnavailable)]


def not_building() -> dict:
    """{device key: why not} for the OpenCL devices whose compiler does not build the kernel."""
    from lutbake.errors import OpenCLUnavailable
    from lutbake.integrate.devices import device_key, opencl_devices
    from lutbake.integrate.program import built_program

    return {
        device_key(d): str(built)
        for d in opencl_devices()
        if isinstance(built := built_program(d, "float64"), OpenCLUnavailable)
    }


def write_report(report: dict, json_path) -> None:
    """Close ``report`` with the load average at the end, print it as JSON and write it to ``json_path`` if given."""
    report["load_average_end"] = load_average()
    text = json.dumps(report, indent=2)
    print(text)
    if json_path:
        Path(json_path).write_text(text + "\n")


def load_average() -> list:
    return [round(v, 2) for v in os.getloadavg()]


def _image(path: Path) -> np.ndarray:
    from lutbake.lut.sample import Lut

    return np.load(path) if path.suffix == ".npy" else Lut.load(path).image.astype(float)


def texel_error(images: dict, spec, n_points: int, seed: int) -> dict:
    """max |ΔRGB| of each image against the ground truth at random texels (all texels if fewer)."""
    from lutbake.spectral.reference import reference_colour

    width, height = spec.image_size
    rng = np.random.default_rng(seed)
    flat = np.arange(width * height) if n_points >= width * height else rng.choice(width * height, n_points, False)
    y, x = np.divmod(flat, width)
    pts = spec.texel_stacks(np.ravel(p)[flat] for p in spec.cell_params(0, height))
    truth = reference_colour(pts, spec.observer, spec.space).values
    return {"texels": int(flat.size), **{name: float(np.abs(img[y, x] - truth).max()) for name, img in images.items()}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--out")
    ap.add_argument("--grid", default="b1")
    ap.add_argument("--compute", default="float64")
    ap.add_argument("--device", default="")
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json")
    ap.add_argument("--skip-numpy", action="store_true")
    ap.add_argument("--pool-runs", type=int, default=3)
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out, args.compute, args.grid, args.device)
        return
    report = {
        "grid": "B1",
        "cells": _spec(1.5, B1_AXES).cells,
        "load_average_start": load_average(),
        "not_building": not_building(),
        "runtimes": {},
    }
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        images, stiff = {}, {}
        for label in devices():
            rows = {}
            for path, compute in (("series", "float64"), ("direct", "float64"), ("series", "float32")):
                key = f"{path}-{compute}"
                out = tmp / f"{label}-{key}.exr"
                rows[key] = run_path(path, out, compute, label)
                images[f"{label}-{key}"] = _image(out)
                stiff_out = tmp / f"stiff-{label}-{key}.exr"
                run_path(path, stiff_out, compute, label, "stiff")
                stiff[f"{label}-{key}"] = _image(stiff_out)
            rows["series_vs_direct_speedup"] = (
                rows["series-float64"]["cells_per_s"] / rows["direct-float64"]["cells_per_s"]
            )
            report["runtimes"][label] = rows
        if args.pool_runs:
            report["exr_pool"] = exr_pool(tmp, next(iter(report["runtimes"])), args.pool_runs)
        if not args.skip_numpy:
            out = tmp / "numpy-2nm.npy"
            report["numpy_2nm"] = run_path("numpy-2nm", out)
            images["numpy-2nm"] = _image(out)
            for rows in report["runtimes"].values():
                rows["series_vs_numpy_2nm_speedup"] = (
                    rows["series-float64"]["cells_per_s"] / report["numpy_2nm"]["cells_per_s"]
                )
                rows["series_vs_numpy_2nm_process_speedup"] = (
                    report["numpy_2nm"]["process_wall_s"] / rows["series-float64"]["process_wall_s"]
                )
        report["rgb_abs_max_vs_ground_truth"] = texel_error(images, _spec(1.5, B1_AXES), args.points, args.seed)
        report["stiff_grid"] = {
            "axes": dict(zip(("cos_theta", "opd_nm", "eta3", "kappa3"), STIFF["axes"])),
            "eta2": STIFF["eta2"],
            "rgb_abs_max_vs_ground_truth": texel_error(stiff, _spec(STIFF["eta2"], STIFF["axes"]), 1 << 30, args.seed),
        }
    write_report(report, args.json)


if __name__ == "__main__":
    main()
