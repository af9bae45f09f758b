"""Accuracy per byte of LUT parameterizations: the √ grid against η3's admittance spacing.

    python bench/bench_parameterization.py [--eta2 1.5] [--points 5000] [--json FILE]

Each layout is baked in half precision with `lutbake.lut.bake.bake` (the shipped path) and scored by
`lutbake.quality.report.report_lut` at the same kind of held-out points as `lutbake report` (half uniform, half
at centres of its own grid's cells, seed 0): p99 and max ΔE00 against the ground truth, and the EXR's
bytes. The layouts pair the previous default counts and the shipped ones with and without the admittance
spacing on η3, so the table separates what the spacing buys from what the bytes buy.
"""

import argparse
import json
import tempfile
from pathlib import Path

from lutbake.grid.spec import BakeSpec, parse_axis
from lutbake.lut.bake import bake
from lutbake.quality.report import report_lut

LAYOUTS = {
    "√ grid, 32×128×16×16 (previous default)": ("0:1:32:sqrt", "0:3000:128", "1:3:16", "0:5:16:sqrt"),
    "admittance η3, 32×128×16×16": ("0:1:32:sqrt", "0:3000:128", "1:3:16:admittance", "0:5:16:sqrt"),
    "√ grid, 40×160×20×20": ("0:1:40:sqrt", "0:3000:160", "1:3:20", "0:5:20:sqrt"),
    "admittance η3, 40×160×20×20 (shipped)": ("0:1:40:sqrt", "0:3000:160", "1:3:20:admittance", "0:5:20:sqrt"),
}
NAMES = ("cos_theta", "opd_nm", "eta3", "kappa3")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--eta2", type=float, default=1.5)
    ap.add_argument("--points", type=int, default=5000)
    ap.add_argument("--json")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, texts) in enumerate(LAYOUTS.items()):
            spec = BakeSpec(
                eta2=args.eta2, axes=tuple(parse_axis(n, t) for n, t in zip(NAMES, texts)), precision="half"
            )
            path = Path(tmp) / f"{i}.exr"
            bake(spec, path)
            err = report_lut(path, n_points=args.points, seed=0, approximations=False).lut.summary()
            rows.append(
                {
                    "layout": name,
                    "axes": list(texts),
                    "exr_bytes": path.stat().st_size,
                    "de00_p99": err["de00_p99"],
                    "de00_max": err["de00_max"],
                }
            )
            print(
                f"{name:42s} {path.stat().st_size / 2**20:5.2f} MiB  p99 {err['de00_p99']:.3f}  "
                f"max {err['de00_max']:.3f}",
                flush=True,
            )
    if args.json:
        Path(args.json).write_text(
            json.dumps({"eta2": args.eta2, "points": args.points, "rows": rows}, indent=2) + "\n"
        )


if __name__ == "__main__":
    main()
