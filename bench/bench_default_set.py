"""The default LUT set (README command 1) against B1 and an independent numpy integration at 2 nm, in one
run, on every OpenCL runtime that builds the kernel; where its time goes, LUT by LUT.

    python bench/bench_default_set.py [--reps 2] [--sample-rows 64] [--device KEY] [--vs DIR] [--overlap N]
                                      [--json FILE]

Per runtime (``--device``: that one only), `lutbake bake --json --out DIR --device KEY` (the six default
LUTs, 15.9 M cells) and `lutbake bake --json` of B1 (4.19 M cells, bench_b1.py's grid) alternate, each in
its own process, --reps times (the runtimes in turn within each rep), after one discarded B1 bake per
runtime (a cold kernel binary cache cost 8 s once): process wall (interpreter start and imports included),
the process's CPU time over its wall (``process_cpu_per_wall``: 2 on 2 cores when both are busy
throughout), cells/s, peak RSS (VmHWM), the texels per path (series, closed form, direct) summed over the
set from the headers, and each LUT's stages as `bake --json` prints them (compile, plan, device, write,
other, the bake's CPU over wall: lutbake/lut/pipeline.py), with their medians over the reps
(``set_stages_median``: per LUT and summed over the set). The ratio of the set's cells/s to B1's is taken
rep by rep (pairing keeps it fair on a busy machine); medians are reported. The numpy 2 nm integration
(bench_b1.numpy_2nm) runs on the first --sample-rows image rows of each default LUT and of B1 (its cost per
texel does not depend on the texel: 236 wavelengths each), giving its cells/s on each, and so each bake's
speed-up over it.

Each stage's CPU seconds, cores busy and idle core-seconds (`bake --json`'s ``stage_cpu_s`` and
``idle_core_s``) are summed over the set too (``plan_cpu_s``, ``plan_cores``, ``plan_idle_core_s``, ...), and
each set bake samples its process's runnable threads (``runnable_mean``, ``share_below_cores``: Sampler of
bench_device_passes.py; a busy machine's waiting threads still count, so they say what a quiet one would run).

``--overlap N``: N pairs of the set baked as `lutbake bake` does and with each next LUT's plan ahead, on a
second queue in a worker thread while the current LUT's bands stream (``plan_ahead``: a measuring probe, not
lutbake's path; docs/spectral.md), in turn: walls pair by pair, CPU, runnable threads, the same bytes or not.

``--vs DIR``: another checkout (its lutbake/ first on PYTHONPATH: e.g. `git worktree add DIR main`) bakes
the set in turn with this one, rep by rep, on each runtime, instead of B1 and numpy: the medians of each
side and of its wall over this one's, pair by pair, and whether the two sets' files are the same bytes.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_b1 import (
    B1_AXES,
    _spec,
    cli_argv,
    cli_json,
    devices,
    load_average,
    not_building,
    numpy_2nm,
    run_child,
    write_report,
)
from bench_device_passes import Sampler


def child(what: str, out: str, device: str, rows: int) -> None:
    """One bake (or numpy sample) in this process; prints one JSON line."""
    from lutbake.lut.bake import default_specs, resident_bytes

    start = time.perf_counter()
    if what in ("serial", "ahead"):
        print(json.dumps(overlap_child(what, Path(out), device)))
        return
    if what.startswith("numpy:"):
        name = what.split(":", 1)[1]
        spec = _spec(1.5, B1_AXES) if name == "b1" else default_specs()[name]
        numpy_2nm(spec, out, rows)
        cells = rows * spec.image_size[0]
        print(
            json.dumps(
                {
                    "name": name,
                    "cells": cells,
                    "wall_s": time.perf_counter() - start,
                    "cells_per_s": cells / (time.perf_counter() - start),
                }
            )
        )
        return
    import lutbake
    from lutbake.io.cores import usable_cores

    argv = (
        ["bake", "--quiet", "--json", "--out", out, "--device", device]
        if what == "set"
        else cli_argv(1.5, B1_AXES, "float64", device, out)
    )
    sampler = Sampler(with_main=True)
    printed = cli_json(argv)
    wall = time.perf_counter() - start
    sampler.stop()
    folder = Path(out) if what == "set" else Path(out).parent
    sidecars = [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]
    paths = {
        key: sum(s["integrator"][key] for s in sidecars)
        for key in ("series_texels", "closed_form_texels", "direct_texels")
    }
    cells = sum(paths.values())
    row = {
        "what": what,
        "lutbake": str(Path(lutbake.__file__).parent),
        "cells": cells,
        "luts": len(sidecars),
        "wall_s": wall,
        "device": sidecars[0]["baked_on"]["device"],
        "texels_per_path": paths,
        "peak_rss_mib": resident_bytes(peak=True) / 2**20,
        "imports_s": printed["imports_s"],
        **sampler.runnable(usable_cores()),
        "stages": {Path(lut["path"]).stem: lut["stages"] for lut in printed["luts"]},
    }
    print(json.dumps(row))


def overlap_child(how: str, out: Path, device: str) -> dict:
    """The default set baked into ``out`` in this process: as `lutbake bake` bakes it (``how`` 'serial':
    bake_default_set) or with each next LUT's plan ahead ('ahead': plan_ahead); the bake's wall and CPU,
    the runnable threads (Sampler) and a digest of the files."""
    import hashlib

    from lutbake.io.cores import usable_cores
    from lutbake.lut.sets import bake_default_set, default_set_jobs

    out.mkdir(parents=True, exist_ok=True)
    cells = sum(spec.cells for _, spec in default_set_jobs(out))
    sampler = Sampler(with_main=True)
    start, cpu = time.perf_counter(), time.process_time()
    if how == "serial":
        bake_default_set(out, device=device)
    else:
        plan_ahead(default_set_jobs(out), device)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    sampler.stop()
    files = sorted(p for p in out.iterdir() if not p.name.startswith("."))
    digest = hashlib.sha256(b"".join(p.name.encode() + p.read_bytes() for p in files)).hexdigest()
    return {"how": how, "cells": cells, "wall_s": wall, "cpu_s": cpu, "cpu_per_wall": cpu / wall, "files": len(files),
            "sha256": digest, **sampler.runnable(usable_cores())}  # fmt: skip


def plan_ahead(jobs: list, device: str) -> None:
    """The default set with LUT k + 1's plan (its probes, device plan and capped texels' error) on a second
    queue of the same device, in a worker thread, while LUT k's bands stream into its EXR (the bands as
    `lutbake bake` cuts them): a measuring probe of that overlap, not lutbake's path (docs/spectral.md)."""
    from concurrent.futures import ThreadPoolExecutor

    import lutbake.lut.bake as lut
    from lutbake.integrate.opencl import backend
    from lutbake.integrate.program import DeviceProgram
    from lutbake.integrate.series import SeriesOnDevice
    from lutbake.io.fileset import open_set
    from lutbake.lut.pipeline import BakeStages, stream_bands
    from lutbake.lut.sets import _banded
    from lutbake.tables.exr import exr_rows
    from lutbake.tables.lutfile import write_companions

    fast = backend("opencl", device=device)
    planner = DeviceProgram(fast.ctx, fast.program.program, fast.compute)  # its own queue and kernels

    def prepare(spec, probes_thread):
        probes = probes_thread.submit(lut.spectral_error, spec)
        series = SeriesOnDevice(planner, spec)
        stats = series.plan().stats  # ends in blocking reads: its buffers are complete for the other queue
        capped = lut.capped_error(spec, None if stats.direct_texels == spec.cells else stats.direct_texels)
        return series, lut.metadata(spec, probes.result(), capped, stats.describe())

    folder = jobs[0][0].parent
    with open_set(folder, "lutbake-default-set") as files, ThreadPoolExecutor(1) as ahead, ThreadPoolExecutor(1) as pt:
        upcoming = ahead.submit(prepare, jobs[0][1], pt)
        for k, (path, spec) in enumerate(jobs):
            series, meta = upcoming.result()
            if k + 1 < len(jobs):
                upcoming = ahead.submit(prepare, jobs[k + 1][1], pt)
            series.program, fast._series = fast.program, series  # the bands on the bake's queue
            chunks = spec.row_chunks(_banded(path, spec, False)["chunk_cells"])
            with exr_rows(files.temp(path), *spec.file_layout.size, meta, spec.precision) as exr:
                stream_bands(fast, spec, exr, chunks, BakeStages())
            write_companions(files, path, meta, {**meta, "baked_on": {"backend": fast.name, "device": fast.device}})


def overlap(tmp: Path, key: str, reps: int) -> dict:
    """``reps`` pairs of the set baked serially and with the next plan ahead (overlap_child), in turn, the
    order swapped every pair: walls pair by pair, CPU, runnable threads, whether the bytes are the same."""
    pairs = []
    for rep in range(reps):
        order = ("serial", "ahead") if rep % 2 == 0 else ("ahead", "serial")
        row = {how: run(how, tmp / f"{how}-{rep}", key) for how in order}
        pairs.append({how: row[how] for how in ("serial", "ahead")})
    keys = ("wall_s", "cpu_s", "cpu_per_wall", "runnable_mean", "share_below_cores")
    return {
        "pairs": pairs,
        **{
            f"{how}_{k}_median": float(np.median([p[how][k] for p in pairs]))
            for how in ("serial", "ahead")
            for k in keys
        },
        "ahead_over_serial_wall_median": float(
            np.median([p["ahead"]["wall_s"] / p["serial"]["wall_s"] for p in pairs])
        ),
        "same_bytes": len({p[how]["sha256"] for p in pairs for how in p}) == 1,
    }


def run(what: str, out: Path, device: str = "", rows: int = 0, checkout: Path | None = None) -> dict:
    if what == "b1":
        out.parent.mkdir(parents=True, exist_ok=True)
    return run_child(__file__, what, "--out", str(out), "--device", device, "--rows", str(rows), checkout=checkout)


PHASES = ("compile", "plan", "device", "write", "other")  # a bake's stages (lutbake/lut/pipeline.py)


def flat_stages(stages: dict) -> dict:
    """One LUT's `bake --json` stages as flat numbers: each phase's wall (``plan_s``), CPU (``plan_cpu_s``)
    and idle core-seconds (``plan_idle_core_s``), the bake's CPU (``cpu_s``)."""
    flat = {"cpu_s": stages["cpu_s"], "idle_core_s": stages["idle_core_s_total"]}
    for phase in PHASES:
        flat[f"{phase}_s"] = stages[f"{phase}_s"]
        flat[f"{phase}_cpu_s"] = stages["stage_cpu_s"][phase]
        flat[f"{phase}_idle_core_s"] = stages["idle_core_s"][phase]
    return flat


def stages_median(runs: list) -> dict:
    """Each LUT's stages (flat_stages) and the set's (summed over its LUTs, with each phase's cores busy:
    its CPU over its wall), median over ``runs``."""
    flats = [{name: flat_stages(stages) for name, stages in r["stages"].items()} for r in runs]
    per_lut = {
        name: {key: float(np.median([f[name][key] for f in flats])) for key in lut} for name, lut in flats[0].items()
    }
    summed = [{key: sum(lut[key] for lut in f.values()) for key in next(iter(f.values()))} for f in flats]
    for s in summed:
        s.update({f"{phase}_cores": s[f"{phase}_cpu_s"] / max(s[f"{phase}_s"], 1e-12) for phase in PHASES})
    return {**per_lut, "set": {key: float(np.median([s[key] for s in summed])) for key in summed[0]}}


def medians(runs: list) -> dict:
    """Process wall, its CPU over wall and cells/s, median over ``runs``."""
    keys = ("process_wall_s", "process_cpu_per_wall", "process_cells_per_s")
    return {f"{key}_median": float(np.median([r[key] for r in runs])) for key in keys}


def versus(tmp: Path, keys: list, reps: int, other: Path) -> dict:
    """The set baked by this checkout and by ``other`` in turn, ``reps`` pairs per runtime."""
    out, sides = {}, [("this", None), ("vs", other.resolve())]
    for key in keys:
        pairs = [
            [run("set", tmp / f"{side}-{key}-{rep}", key, checkout=checkout) for side, checkout in sides]
            for rep in range(reps)
        ]
        same = all(
            (tmp / f"this-{key}-0" / p.name).read_bytes() == p.read_bytes() for p in (tmp / f"vs-{key}-0").iterdir()
        )
        out[key] = {
            **{
                side: {"runs": [p[i] for p in pairs], **medians([p[i] for p in pairs])}
                for i, side in enumerate(("this", "vs"))
            },
            "vs_over_this_wall_median": float(np.median([b["process_wall_s"] / a["process_wall_s"] for a, b in pairs])),
            "same_bytes": same,
        }
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--out")
    ap.add_argument("--device", default="", help="one runtime's key (default: every runtime that builds)")
    ap.add_argument("--rows", type=int, default=0)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--sample-rows", type=int, default=64)
    ap.add_argument("--vs", type=Path, help="another checkout, baking the set in turn with this one")
    ap.add_argument("--overlap", type=int, default=0, help="pairs of the set serial and with the next plan ahead")
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.overlap and args.vs:
        ap.error("--overlap and --vs measure different things: give one of them")
    if args.child:
        child(args.child, args.out, args.device, args.rows)
        return
    report = {"load_average_start": load_average(), "not_building": not_building()}
    keys = [args.device] if args.device else devices()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for key in keys:
            run("b1", tmp / f"warm-{key}" / "b1.exr", key)  # discarded: builds the kernel's binary cache
        if args.overlap:
            report["overlap"] = {key: overlap(tmp, key, args.overlap) for key in keys}
        elif args.vs:
            report["versus"] = {"vs": args.vs.name, "runtimes": versus(tmp, keys, args.reps, args.vs)}
        else:
            report.update(against_b1_and_numpy(tmp, keys, args.reps, args.sample_rows))
    write_report(report, args.json)


def against_b1_and_numpy(tmp: Path, keys: list, reps: int, sample_rows: int) -> dict:
    """The set and B1 in turn, ``reps`` times per runtime, and both against numpy at 2 nm."""
    from lutbake.lut.bake import default_specs

    by_key = {key: {"set": [], "b1": []} for key in keys}
    for rep in range(reps):  # the runtimes alternate within each rep: a busy spell hits them alike
        for key in keys:
            by_key[key]["b1"].append(run("b1", tmp / f"b1-{key}-{rep}" / "b1.exr", key))
            by_key[key]["set"].append(run("set", tmp / f"set-{key}-{rep}", key))
    samples = {
        name: run(f"numpy:{name}", tmp / f"numpy-{name}.npy", rows=sample_rows) for name in ["b1", *default_specs()]
    }
    set_rate = sum(r["cells"] for name, r in samples.items() if name != "b1") / sum(
        r["wall_s"] for name, r in samples.items() if name != "b1"
    )
    runtimes = {}
    for key, runs in by_key.items():
        ratios = [s["process_cells_per_s"] / b["process_cells_per_s"] for s, b in zip(runs["set"], runs["b1"])]
        set_cells_per_s, b1_cells_per_s = (medians(runs[what])["process_cells_per_s_median"] for what in ("set", "b1"))
        runtimes[key] = {
            "runs": runs,
            "set_over_b1_cells_per_s": ratios,
            "set_over_b1_cells_per_s_median": float(np.median(ratios)),
            **{f"{what}_{name}": value for what in runs for name, value in medians(runs[what]).items()},
            "set_stages_median": stages_median(runs["set"]),
            "b1_stages_median": stages_median(runs["b1"])["b1"],
            "set_over_numpy_2nm": set_cells_per_s / set_rate,
            "b1_over_numpy_2nm": b1_cells_per_s / samples["b1"]["cells_per_s"],
        }
    return {
        "runtimes": runtimes,
        "numpy_2nm_sample": samples,
        "numpy_2nm_cells_per_s": {"b1": samples["b1"]["cells_per_s"], "default_set": set_rate},
    }


if __name__ == "__main__":
    main()
