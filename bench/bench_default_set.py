"""The default LUT set (README command 1) against B1 and an independent numpy integration at 2 nm, in one
run, on every OpenCL runtime that builds the kernel.

    python bench/bench_default_set.py [--reps 2] [--sample-rows 64] [--json FILE]

Per runtime, `lutbake bake --out DIR --device KEY` (the six default LUTs, 14.4 M cells) and
`lutbake bake` of B1 (4.19 M cells, bench_b1.py's grid) alternate, each in its own process, --reps
times (the runtimes in turn within each rep), after one discarded B1 bake per runtime (a cold kernel
binary cache cost 8 s once): process wall (interpreter
start and imports included), cells/s, peak RSS (VmHWM) and, from the headers, the texels per path
(series, closed form, direct) summed over the set. The ratio of the set's cells/s to B1's is taken rep
by rep (pairing keeps it fair on a busy machine); medians are reported. The numpy 2 nm integration
(bench_b1.numpy_2nm) runs on the first --sample-rows image rows of each default LUT and of B1 (its cost per
texel does not depend on the texel: 236 wavelengths each), giving its cells/s on each, and so each bake's
speed-up over it.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_b1 import B1_AXES, _spec, cli_argv, devices, load_average, not_building, numpy_2nm, run_child, write_report


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
    from lutbake.cli import main

    argv = (
        ["bake", "--quiet", "--out", out, "--device", device]
        if what == "set"
        else cli_argv(1.5, B1_AXES, "float64", device, out)
    )
    sys.argv = ["lutbake", *argv]
    try:
        main()
    except SystemExit as exc:
        if exc.code:
            raise
    wall = time.perf_counter() - start
    folder = Path(out) if what == "set" else Path(out).parent
    sidecars = [json.loads(p.read_text()) for p in sorted(folder.glob("*.json"))]
    paths = {
        key: sum(s["integrator"][key] for s in sidecars)
        for key in ("series_texels", "closed_form_texels", "direct_texels")
    }
    cells = sum(paths.values())
    print(
        json.dumps(
            {
                "what": what,
                "cells": cells,
                "luts": len(sidecars),
                "wall_s": wall,
                "device": sidecars[0]["baked_on"]["device"],
                "texels_per_path": paths,
                "peak_rss_mib": resident_bytes(peak=True) / 2**20,
            }
        )
    )


def run(what: str, out: Path, device: str = "", rows: int = 0) -> dict:
    if what == "b1":
        out.parent.mkdir(parents=True, exist_ok=True)
    return run_child(__file__, what, "--out", str(out), "--device", device, "--rows", str(rows))


def main() -> None:
    from lutbake.lut.bake import default_specs

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--child")
    ap.add_argument("--out")
    ap.add_argument("--device", default="")
    ap.add_argument("--rows", type=int, default=0)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--sample-rows", type=int, default=64)
    ap.add_argument("--json")
    args = ap.parse_args()
    if args.child:
        child(args.child, args.out, args.device, args.rows)
        return
    report = {"load_average_start": load_average(), "not_building": not_building(), "runtimes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        keys = devices()
        by_key = {key: {"set": [], "b1": []} for key in keys}
        for key in keys:
            run("b1", tmp / f"warm-{key}" / "b1.exr", key)  # discarded: builds the kernel's binary cache
        for rep in range(args.reps):  # the runtimes alternate within each rep: a busy spell hits them alike
            for key in keys:
                by_key[key]["b1"].append(run("b1", tmp / f"b1-{key}-{rep}" / "b1.exr", key))
                by_key[key]["set"].append(run("set", tmp / f"set-{key}-{rep}", key))
        for key, runs in by_key.items():
            ratios = [s["process_cells_per_s"] / b["process_cells_per_s"] for s, b in zip(runs["set"], runs["b1"])]
            report["runtimes"][key] = {
                "runs": runs,
                "set_over_b1_cells_per_s": ratios,
                "set_over_b1_cells_per_s_median": float(np.median(ratios)),
                **{
                    f"{what}_process_wall_s_median": float(np.median([r["process_wall_s"] for r in runs[what]]))
                    for what in runs
                },
            }
        samples = {
            name: run(f"numpy:{name}", tmp / f"numpy-{name}.npy", rows=args.sample_rows)
            for name in ["b1", *default_specs()]
        }
    report["numpy_2nm_sample"] = samples
    set_rate = sum(r["cells"] for name, r in samples.items() if name != "b1") / sum(
        r["wall_s"] for name, r in samples.items() if name != "b1"
    )
    report["numpy_2nm_cells_per_s"] = {"b1": samples["b1"]["cells_per_s"], "default_set": set_rate}
    for rows in report["runtimes"].values():
        rows["set_over_numpy_2nm"] = (
            float(np.median([r["process_cells_per_s"] for r in rows["runs"]["set"]])) / set_rate
        )
        rows["b1_over_numpy_2nm"] = (
            float(np.median([r["process_cells_per_s"] for r in rows["runs"]["b1"]])) / samples["b1"]["cells_per_s"]
        )
    write_report(report, args.json)


if __name__ == "__main__":
    main()
