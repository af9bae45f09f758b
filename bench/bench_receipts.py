"""Receipts of the IridescenceMetallicSpheres sphere grid (`lutbake report OUT/ASSET.json`): the batched ground
truth (consecutive materials' stacks integrated together, once per distinct stack) against the per-part one (once
per part and mapping), in one run.

    python bench/bench_receipts.py [--every 8] [--full] [--points 1000] [--work DIR] [--json FILE]

The asset is rebuilt from tests/fixtures/khronos_iridescence.json by tests/gltf_assets.py (343 spheres: film
thickness x grey metal base x film index); --every K keeps every K-th sphere (default 8: 43 materials, every
film index and base level present), --full keeps all 343. It is baked once (`lutbake bake --gltf`, kept in
--work, reused when the folder holds its manifest). Each path then runs the receipts in a fresh interpreter
(the library call `report` makes, --points per part, seed 0), alternating the order over --repeats:
wall, CPU/wall, peak resident memory, ground-truth integrations (calls to the truth) and points integrated.
Reported: each path's figures, batched / per-part wall, and the largest difference between the two
receipts' numbers (the same receipts to rounding: the truth differs only by where points fall in its chunks).
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
sys.path.insert(0, str(ROOT / "tests"))

from gltf_assets import document, khronos_document, write_gltf  # noqa: E402 - the tests' asset builder

ASSET = "IridescenceMetallicSpheres"


def baked(work: Path, every: int) -> Path:
    """The manifest of the sphere grid (every ``every``-th material) baked into ``work``, baking it once."""
    manifest = work / "out" / "grid.json"
    if manifest.exists():
        return manifest
    spheres = khronos_document(ASSET)["materials"][:343:every]
    gltf = write_gltf(work / "grid.gltf", document(spheres))
    proc = subprocess.run(
        [sys.executable, "-m", "lutbake", "bake", "--gltf", str(gltf), "--out", str(work / "out")],
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        raise SystemExit(f"bake failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return manifest


def child(manifest: str, batched: bool, points: int, out: str) -> None:
    """One path's receipts in this interpreter, timed, with the truth's calls counted."""
    from lutbake.scene.gltf import receipt, scoring

    counts = {"truth_integrations": 0, "points_integrated": 0}

    def counted(stack):
        counts["truth_integrations"] += 1
        counts["points_integrated"] += len(stack)
        return truth(stack)

    truth = scoring.truth_rgb
    receipt.truth_rgb = scoring.truth_rgb = counted
    wall, cpu = time.perf_counter(), time.process_time()
    receipts = receipt.gltf_receipts(manifest, points, 0, shared_truth=batched)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    figures = {"wall_s": wall, "cpu_over_wall": cpu / wall, "peak_rss_mib": peak_mib, **counts}
    Path(out).write_text(json.dumps({"figures": figures, "receipts": receipts}))


def run_path(manifest: Path, batched: bool, points: int, folder: Path) -> dict:
    out = folder / f"{'batched' if batched else 'per-part'}.json"
    argv = [sys.executable, __file__, "--child", str(manifest), "--batched", str(int(batched))]
    subprocess.run([*argv, "--points", str(points), "--result", str(out)], check=True)
    return json.loads(out.read_text())


def largest_difference(a, b, where="") -> tuple[float, str]:
    """The largest |a - b| over two receipts' numbers (relative above 1), and where; structure must match."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), where
        return max((largest_difference(a[k], b[k], f"{where}.{k}") for k in a), default=(0.0, where))
    if isinstance(a, list):
        assert len(a) == len(b), where
        return max(
            (largest_difference(x, y, f"{where}[{i}]") for i, (x, y) in enumerate(zip(a, b))), default=(0.0, where)
        )
    if isinstance(a, float) and isinstance(b, float):
        return abs(a - b) / max(1.0, abs(a)), where
    assert a == b, (where, a, b)
    return 0.0, where


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--every", type=int, default=8, help="keep every K-th sphere (default 8: 43 materials)")
    ap.add_argument("--full", action="store_true", help="all 343 spheres (same as --every 1)")
    ap.add_argument("--points", type=int, default=1000, help="points per part (report's --points; default 1000)")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each path, order alternated")
    ap.add_argument("--work", type=Path, help="folder keeping the bake between runs (default: a temporary one)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--batched", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        return child(args.child, bool(args.batched), args.points, args.result)
    every = 1 if args.full else args.every
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        manifest = baked(work, every)
        runs: dict[str, list] = {"batched": [], "per-part": []}
        for k in range(args.repeats):
            for batched in (True, False) if k % 2 == 0 else (False, True):
                result = run_path(manifest, batched, args.points, Path(tmp))
                runs["batched" if batched else "per-part"].append(result)
                print(("batched " if batched else "per-part"), json.dumps(result["figures"]), flush=True)
    first = {name: r[0]["receipts"] for name, r in runs.items()}
    diff, where = largest_difference(first["batched"], first["per-part"])
    walls = {name: min(r["figures"]["wall_s"] for r in rs) for name, rs in runs.items()}
    doc = {
        "asset": f"{ASSET}, every {every}th sphere ({len(first['batched']['materials'])} materials)",
        "points_per_part": args.points,
        "load_average": os.getloadavg(),
        "paths": {name: [r["figures"] for r in rs] for name, rs in runs.items()},
        "batched_over_per_part_wall": walls["batched"] / walls["per-part"],
        "largest_receipt_difference": {"value": diff, "at": where},
    }
    print(json.dumps({k: v for k, v in doc.items() if k != "paths"}, indent=2))
    if args.json:
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
