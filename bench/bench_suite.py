"""The test suite's wall time and where it goes: per pytest-xdist worker, per module, per test.

    python bench/bench_suite.py [--top 15] [--json FILE] [-- PYTEST ARGS]

Runs `python -m pytest -q` (the README's command, pyproject's `-n auto --dist loadscope`) with this
file as a plugin that records, for every test, its worker, start and end, and the CPU time its
worker process and the processes it waited for used meanwhile (setup, call and teardown together,
so a module-scoped fixture counts in the first test that uses it). Prints the wall time, the load
average before and after (the suite shares the machine with whatever else runs), each worker's
modules in the order it ran them with their wall and CPU seconds, and the tests that used the most
CPU. Wall ≈ CPU per worker (plus start-up and collection: imports and the OpenCL device survey) on an
idle machine; more means other work competed for the cores.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_RECORD = "LUTBAKE_BENCH_SUITE_RECORD"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    """Plugin side (in each worker): time one test's whole protocol."""
    start, before = time.time(), os.times()
    yield
    after = os.times()
    cpu = sum(getattr(after, f) - getattr(before, f) for f in ("user", "system", "children_user", "children_system"))
    with open(os.environ[_RECORD], "a") as fh:
        fh.write(
            json.dumps(
                {
                    "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"),
                    "test": item.nodeid,
                    "start": start,
                    "end": time.time(),
                    "cpu_s": cpu,
                }
            )
            + "\n"
        )


def summarize(rows: list, top: int) -> dict:
    t0 = min(r["start"] for r in rows)
    workers = defaultdict(list)
    for r in sorted(rows, key=lambda r: r["start"]):
        workers[r["worker"]].append(r)
    out = {"workers": {}, "tests": []}
    for worker, tests in sorted(workers.items()):
        modules = {}
        for r in tests:
            m = modules.setdefault(r["test"].split("::")[0], {"start_s": r["start"] - t0, "wall_s": 0.0, "cpu_s": 0.0})
            m["wall_s"] += r["end"] - r["start"]
            m["cpu_s"] += r["cpu_s"]
        out["workers"][worker] = {
            "end_s": max(r["end"] for r in tests) - t0,
            "cpu_s": sum(r["cpu_s"] for r in tests),
            "modules": modules,
        }
    out["cpu_s"] = sum(r["cpu_s"] for r in rows)
    out["tests"] = [
        {"test": r["test"], "cpu_s": r["cpu_s"], "wall_s": r["end"] - r["start"]}
        for r in sorted(rows, key=lambda r: -r["cpu_s"])[:top]
    ]
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument("--json", type=Path)
    parser.add_argument("pytest_args", nargs="*")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "tests.jsonl"
        env = {
            **os.environ,
            _RECORD: str(record),
            "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), str(ROOT / "bench"), os.environ.get("PYTHONPATH")])),
        }
        load_before, start = os.getloadavg()[0], time.time()
        proc = subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "bench_suite", "-p", "no:cacheprovider", *args.pytest_args],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
        )
        wall, load_after = time.time() - start, os.getloadavg()[0]
        rows = [json.loads(line) for line in record.read_text().splitlines()]
    doc = {
        "wall_s": wall,
        "returncode": proc.returncode,
        "summary": proc.stdout.strip().splitlines()[-1],
        "load_average_1min": [load_before, load_after],
        **summarize(rows, args.top),
    }
    print(
        f"{doc['summary']}: wall {wall:.0f} s, load average {load_before:.2f} -> {load_after:.2f}, "
        f"CPU {doc['cpu_s']:.0f} s over all workers"
    )
    for worker, w in doc["workers"].items():
        print(f"{worker}: ends at {w['end_s']:.0f} s, CPU {w['cpu_s']:.0f} s")
        for name, m in w["modules"].items():
            print(f"    {m['start_s']:6.1f} s  {name:36s} wall {m['wall_s']:6.1f} s  CPU {m['cpu_s']:6.1f} s")
    print("tests using the most CPU (s):")
    for t in doc["tests"]:
        print(f"  {t['cpu_s']:6.1f} CPU  {t['wall_s']:6.1f} wall  {t['test']}")
    if args.json:
        args.json.write_text(json.dumps(doc, indent=1) + "\n")
    sys.exit(proc.returncode)


if __name__ == "__main__":
    main()
