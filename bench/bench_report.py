"""`lutbake report` of a default LUT: wall, CPU over wall and cost per searched evaluation, this checkout
against another (``--vs``), run in turn, with the searched maxima compared.

    python bench/bench_report.py [--lut lutbake-luts/lutbake-eta2-1.50.exr] [--runs 2] [--vs DIR] [--json FILE]

Each run is `python -m lutbake.cli report --json --quiet LUT` in a fresh process with a checkout's
folder first on PYTHONPATH (this repository, then ``--vs DIR``: e.g. `git worktree add DIR main` for the
figure before a change), alternating A B A B so that both see the same load; the ratio is taken pair by
pair and its median reported. Each row gives the median wall, CPU (user + system of the child) over wall,
the evaluations the worst-case searches spent (every row of the report: the LUT and each engine
approximation) and wall per evaluation. ``same_searched_max``: every row's searched max ΔE00 (to the truth's
rounding, DE00_ROUNDING), where it is and its evaluations are equal in both checkouts (a faster report must
search as thoroughly). The LUT comes from `lutbake bake` (README command 1).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_LUT = ROOT / "lutbake-luts" / "lutbake-eta2-1.50.exr"


def run_report(checkout: Path, lut: Path) -> dict:
    """One `lutbake report --json` with ``checkout`` first on PYTHONPATH: its wall, CPU and summary."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")])}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", "report", "--json", "--quiet", str(lut)],
        capture_output=True,
        text=True,
        env=env,
        cwd=checkout,
    )
    wall = time.perf_counter() - start
    if proc.returncode not in (0, 1):  # 1: a gate failed, still a report
        raise SystemExit(f"report in {checkout} failed: {proc.stderr.strip()}")
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall_s": wall, "cpu_s": cpu, "summary": json.loads(proc.stdout)}


def searched(summary: dict) -> list:
    """Each searched row's (name, max ΔE00, where, evaluations): what two equally thorough reports share."""
    rows = [summary["lut_error"], *summary.get("approximations", [])]
    where = ("de00_max", "cos_theta", "opd_nm", "eta3", "kappa3", "evaluations")
    return [(row["name"], *(row["worst_case"][k] for k in where)) for row in rows if row.get("worst_case")]


# A searched max's ΔE00 is scored against the ground truth, which two checkouts may compute to different
# rounding (physics/fringes.py vs optics: RGB within ~1e-12, tests/spectral/test_spectral.py); ΔE00 amplifies
# an RGB change by at most ~1e3 (at the darkest colours a LUT holds), so equal maxima agree to 1e-9.
DE00_ROUNDING = 1e-9


def same_searched(a: list, b: list) -> bool:
    """Both reports searched the same rows to the same places with the same evaluations, and their maxima
    agree to DE00_ROUNDING."""
    return len(a) == len(b) and all(
        x[0] == y[0] and x[2:] == y[2:] and abs(x[1] - y[1]) <= DE00_ROUNDING for x, y in zip(a, b)
    )


def describe(runs: list) -> dict:
    evaluations = sum(row[-1] for row in searched(runs[0]["summary"]))
    wall = statistics.median(r["wall_s"] for r in runs)
    return {
        "wall_s": wall,
        "walls_s": [r["wall_s"] for r in runs],
        "cpu_per_wall": statistics.median(r["cpu_s"] / r["wall_s"] for r in runs),
        "searched_evaluations": evaluations,
        "wall_per_evaluation_ms": 1e3 * wall / max(evaluations, 1),
        "lut_de00_max": runs[0]["summary"]["lut_error"]["de00_max"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lut", type=Path, default=DEFAULT_LUT)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--vs", type=Path, help="another checkout (its lutbake/ first on PYTHONPATH)")
    ap.add_argument("--json")
    args = ap.parse_args()
    if not args.lut.is_file():
        raise SystemExit(f"{args.lut} missing: bake the default set first (`lutbake bake`)")
    checkouts = {"this": ROOT, **({"vs": args.vs.resolve()} if args.vs else {})}
    runs: dict[str, list] = {name: [] for name in checkouts}
    for _ in range(args.runs):
        for name, checkout in checkouts.items():
            runs[name].append(run_report(checkout, args.lut.resolve()))
    report = {
        "lut": args.lut.name,
        "load_average": [round(v, 2) for v in os.getloadavg()],
        "checkouts": {name: path.name for name, path in checkouts.items()},  # names only: no machine paths
        **{name: describe(r) for name, r in runs.items()},
    }
    if args.vs:
        report["vs_over_this_wall"] = statistics.median(
            b["wall_s"] / a["wall_s"] for a, b in zip(runs["this"], runs["vs"])
        )
        report["same_searched_max"] = all(
            same_searched(searched(a["summary"]), searched(b["summary"])) for a, b in zip(runs["this"], runs["vs"])
        )
    text = json.dumps(report, indent=2)
    print(text)
    if args.json:
        Path(args.json).write_text(text + "\n")


if __name__ == "__main__":
    main()
