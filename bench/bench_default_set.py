"""The default LUT set (README command 1) against B1 and an independent numpy integration at 2 nm, in one
run, on every OpenCL runtime that builds the kernel; where its time goes, LUT by LUT.

    python bench/bench_default_set.py [--reps 2] [--sample-rows 64] [--device KEY] [--vs DIR] [--json FILE]

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


def child(what: str, out: str, device: str, rows: int) -> None:
    """One bake (or numpy sample) in this process; prints one JSON line."""
    from lutbake.lut.bake import default_specs, resident_bytes

    start = time.perf_counter()
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

    argv = (
        ["bake", "--quiet", "--json", "--out", out, "--device", device]
        if what == "set"
        else cli_argv(1.5, B1_AXES, "float64", device, out)
    )
    printed = cli_json(argv)
    wall = time.perf_counter() - start
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
        "stages": {Path(lut["path"]).stem: lut["stages"] for lut in printed["luts"]},
    }
    print(json.dumps(row))


def run(what: str, out: Path, device: str = "", rows: int = 0, checkout: Path | None = None) -> dict:
    if what == "b1":
        out.parent.mkdir(parents=True, exist_ok=True)
    return run_child(__file__, what, "--out", str(out), "--device", device, "--rows", str(rows), checkout=checkout)


STAGES = ("compile_s", "plan_s", "device_s", "write_s", "other_s", "cpu_s")  # summed over a set


def stages_median(runs: list) -> dict:
    """Each LUT's stages (and the set's, summed over its LUTs), median over ``runs``."""
    per_lut = {
        name: {stage: float(np.median([r["stages"][name][stage] for r in runs])) for stage in stages}
        for name, stages in runs[0]["stages"].items()
    }
    summed = [{stage: sum(lut[stage] for lut in r["stages"].values()) for stage in STAGES} for r in runs]
    return {**per_lut, "set": {stage: float(np.median([s[stage] for s in summed])) for stage in STAGES}}


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
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out, args.device, args.rows)
        return
    report = {"load_average_start": load_average(), "not_building": not_building()}
    keys = [args.device] if args.device else devices()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for key in keys:
            run("b1", tmp / f"warm-{key}" / "b1.exr", key)  # discarded: builds the kernel's binary cache
        if args.vs:
            report["versus"] = {"vs": str(args.vs), "runtimes": versus(tmp, keys, args.reps, args.vs)}
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
