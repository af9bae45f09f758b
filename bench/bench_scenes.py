"""Scene bakes: each example scene (examples/*.toml) baked from scratch, timed.

    python bench/bench_scenes.py [--json bench/scenes-result.json]

Each scene runs `lutbake bake --scene examples/X.toml --out TMP --force --json`
in a fresh interpreter with the repository first on PYTHONPATH. Recorded per
scene: the bake's own seconds (`seconds` in the JSON: bake_scene from plan to
commit, including the OpenCL device's start-up and self-check), the wall time
of the whole command (adds the interpreter and imports), the CPU seconds of
the whole command (user + system, every thread: less sensitive than wall time
to other work on a shared machine), the jobs computed,
the device that ran them, and the largest p99 ΔE00 reached, bound held (what
the target holds at any seed: docs/scene.md) and searched max against the
scene's target. Also recorded once: what every bake pays before its first
job, measured in a fresh interpreter the same way (the OpenCL program's build
and self-check, and colour-science's import where its tables are not cached
yet), so it can be told apart from the scene's own work: a scene's compute is
its bake seconds less that start-up (a one-time process cost). The target of issue 12 is < 2 s
of compute per scene. The machine's 1-minute load average is recorded with
every row (taken just before its bake): rerun when it is above 2.5.

PoCL keeps the binaries it builds (the program, and a work-group function
per work-group size a kernel is launched with) in its cache folder, so a
scene's first bake on a machine can cost more than its next ones:
``--cold-pocl-cache`` runs every bake with an empty one and counts what PoCL
built.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _children_cpu() -> float:
    """User + system CPU seconds of finished child processes (all their threads): less sensitive than
    wall time to other work on a shared machine."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _env(pocl_cache: Path | None) -> dict:
    """The repository first on PYTHONPATH; with ``pocl_cache``, PoCL's kernel cache there (fresh: cold)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return {**env, "POCL_CACHE_DIR": str(pocl_cache)} if pocl_cache else env


def bake(scene: Path, out: Path, pocl_cache: Path | None = None) -> dict:
    args = [sys.executable, "-m", "lutbake", "bake", "--scene", str(scene), "--out", str(out), "--force", "--json"]
    start, cpu = time.perf_counter(), _children_cpu()
    done = subprocess.run(args, capture_output=True, text=True, env=_env(pocl_cache))
    wall, cpu = time.perf_counter() - start, _children_cpu() - cpu
    if done.returncode not in (0, 1):
        raise SystemExit(f"{scene.name}: exit {done.returncode}: {done.stderr.strip()}")
    doc = json.loads(done.stdout)
    manifest = json.loads((out / f"{scene.stem}.json").read_text())
    entries = manifest["materials"].values()
    p99, bound, searched = (max(m[k] for m in entries) for k in ("de00_p99", "de00_p99_bound", "de00_max"))
    row = {
        "scene": scene.name,
        "bake_seconds": doc["seconds"],
        "wall_seconds": wall,
        "cpu_seconds": cpu,
        "device": doc["device"],
        "jobs_computed": len(doc["computed"]),
        "de00_p99_max": p99,
        "de00_p99_bound_max": bound,
        "de00_max": searched,
        "target_de00_p99": manifest["settings"]["max_de"],
        "exit": done.returncode,
    }
    if pocl_cache:  # the binaries PoCL built for this bake: the program and its work-group functions
        row["pocl_builds"] = len(list(pocl_cache.rglob("*.so")))
    return row


STARTUP = (
    "import time; t = time.perf_counter(); from lutbake.integrate.opencl import backend; backend(); "
    "print(time.perf_counter() - t)"
)


def startup_seconds(pocl_cache: Path | None = None) -> float:
    done = subprocess.run(
        [sys.executable, "-c", STARTUP], capture_output=True, text=True, env=_env(pocl_cache), check=True
    )
    return float(done.stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument(
        "--cold-pocl-cache",
        action="store_true",
        help="each bake (and the start-up) with an empty PoCL kernel cache, as on a machine that "
        "has not met its kernels yet; rows record how many binaries PoCL built",
    )
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        cold = (lambda name: Path(tmp) / "pocl" / name) if opts.cold_pocl_cache else (lambda name: None)
        startup = startup_seconds(cold("startup"))
        print(f"device start-up (colour-science import, kernel build and self-check): {startup:.2f} s")
        rows = []
        for scene in sorted((ROOT / "examples").glob("*.toml")):
            load = os.getloadavg()[0]  # before the bake: includes the previous bake's tail
            rows.append({**bake(scene, Path(tmp) / scene.stem, cold(scene.stem)), "load_average_1min": load})
            r = rows[-1]
            r["compute_seconds"] = r["bake_seconds"] - startup
            print(
                f"{r['scene']:<22} bake {r['bake_seconds']:6.2f} s  compute {r['compute_seconds']:6.2f} s  "
                f"wall {r['wall_seconds']:6.2f} s  CPU {r['cpu_seconds']:6.2f} s  "
                f"jobs {r['jobs_computed']}  p99 ΔE00 {r['de00_p99_max']:.3f} bound {r['de00_p99_bound_max']:.3f} "
                f"(target {r['target_de00_p99']:g}) max {r['de00_max']:.3f}  "
                f"load {r['load_average_1min']:.2f}  {r['device']}"
                + (f"  PoCL builds {r['pocl_builds']}" if "pocl_builds" in r else ""),
                flush=True,
            )
    if opts.json:
        doc = {
            "load_average_1min": os.getloadavg()[0],
            "device_startup_seconds": startup,
            "pocl_cache": "cold" if opts.cold_pocl_cache else "as found",
            "scenes": rows,
        }
        opts.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
