"""Start-up time of the command line: `lutbake --help` and `lutbake eval` on one point.

    python bench/bench_startup.py [--runs 7] [--json FILE]

Each command runs in a fresh interpreter (`python -m lutbake ...`) with the
repository first on PYTHONPATH; the figure is the median wall time of the
runs (the first run warms the file cache and is not counted). The target for
`--help` is <= 0.5 s: colour-science (which pulls in matplotlib) and the
numeric modules are imported only by the commands that compute.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = {  # argument lists after `python`; the bare interpreter is the floor on this machine
    "python -c pass": ["-c", "pass"],
    "lutbake --help": ["-m", "lutbake", "--help"],
    "lutbake eval (one point)": [
        "-m",
        "lutbake",
        "eval",
        "--eta2",
        "1.33",
        "--thickness",
        "300",
        "--angle",
        "30",
        "--eta3",
        "1.5",
    ],
}


def wall_seconds(args) -> float:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    start = time.perf_counter()
    subprocess.run([sys.executable, *args], check=True, capture_output=True, env=env)
    return time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--json", type=Path, help="also write the results here")
    opts = parser.parse_args()
    results = []
    for name, args in COMMANDS.items():
        wall_seconds(args)  # warm-up
        times = [wall_seconds(args) for _ in range(opts.runs)]
        results.append(
            {
                "command": name,
                "runs": opts.runs,
                "median_s": statistics.median(times),
                "min_s": min(times),
                "max_s": max(times),
            }
        )
        print(
            f"{name:<28} median {statistics.median(times):.3f} s  (min {min(times):.3f}, max {max(times):.3f}, "
            f"{opts.runs} runs)"
        )
    if opts.json:
        opts.json.write_text(json.dumps(results, indent=2) + "\n")


if __name__ == "__main__":
    main()
