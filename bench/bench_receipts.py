"""Receipts of the IridescenceMetallicSpheres sphere grid (`lutbake report OUT/ASSET.json`) with the ground truth's
reflectance by physics/fringes.py where it applies (path "fringes", what `report` runs) against optics at every
node (path "optics", the truth before it), in one run; "per-part" (the truth once per part and mapping instead of
once per distinct stack over batched materials, fringes on) can be added.

    python bench/bench_receipts.py [--every 8] [--full] [--points 1000] [--paths fringes,optics] [--work DIR]
                                   [--json FILE]

The asset is rebuilt from tests/fixtures/khronos_iridescence.json by tests/gltf_assets.py (343 spheres: film
thickness x grey metal base x film index); --every K keeps every K-th sphere (default 8: 43 materials, every
film index and base level present), --full keeps all 343. It is baked once (`lutbake bake --gltf`, kept in
--work, reused when the folder holds its manifest). Each path then runs the receipts in a fresh interpreter
(the library call `report` makes, --points per part, seed 0), alternating the order over --repeats:
wall, CPU/wall, peak resident memory, ground-truth integrations (calls to the truth), points integrated and
reflectance evaluations (point x wavelength node pairs, and the share fringes took). Reported: each path's
figures, the first path's wall over the second's, and the largest difference between their receipts' numbers
(relative above 1; the truth of both is within rounding of the exact integral, docs/optics.md).
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


PATHS = {"fringes": (True, True), "optics": (True, False), "per-part": (False, True)}  # (batched, fringes)


def child(manifest: str, path: str, points: int, out: str) -> None:
    """One path's receipts in this interpreter, timed, with the truth's calls and reflectance nodes counted."""
    import numpy as np

    from lutbake.scene.gltf import receipt, scoring
    from lutbake.spectral import reference

    batched, fringes = PATHS[path]
    counts = {"truth_integrations": 0, "points_integrated": 0}
    nodes: list[tuple[int, int]] = []  # (pairs, pairs by fringes) per call; list.append is atomic across threads

    def counted(stack):
        counts["truth_integrations"] += 1
        counts["points_integrated"] += len(stack)
        return truth(stack)

    def counted_reflectance(points, wavelength_nm):
        fast = int(np.count_nonzero(reference.fringe_points(points)))
        nodes.append((len(points) * wavelength_nm.size, fast * wavelength_nm.size))
        return reflectance(points, wavelength_nm)

    truth, reflectance = scoring.truth_rgb, reference.unpolarized_reflectance
    receipt.truth_rgb = scoring.truth_rgb = counted
    reference.unpolarized_reflectance = counted_reflectance
    if not fringes:
        reference.fringe_points = lambda points: np.zeros(len(points), bool)
    wall, cpu = time.perf_counter(), time.process_time()
    receipts = receipt.gltf_receipts(manifest, points, 0, shared_truth=batched)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    pairs = sum(n for n, _ in nodes)
    figures = {"wall_s": wall, "cpu_over_wall": cpu / wall, "peak_rss_mib": peak_mib, **counts}
    figures |= {"node_evaluations": pairs, "fringe_share": sum(f for _, f in nodes) / max(pairs, 1)}
    Path(out).write_text(json.dumps({"figures": figures, "receipts": receipts}))


def run_path(manifest: Path, path: str, points: int, folder: Path) -> dict:
    out = folder / f"{path}.json"
    argv = [sys.executable, __file__, "--child", str(manifest), "--path", path]
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
    ap.add_argument("--paths", default="fringes,optics", help="two or more of fringes, optics, per-part")
    ap.add_argument("--repeats", type=int, default=1, help="runs of each path, order alternated")
    ap.add_argument("--work", type=Path, help="folder keeping the bake between runs (default: a temporary one)")
    ap.add_argument("--json", type=Path, help="write the figures here")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--path", choices=PATHS, help=argparse.SUPPRESS)
    ap.add_argument("--result", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        return child(args.child, args.path, args.points, args.result)
    paths = args.paths.split(",")
    if len(paths) < 2 or not set(paths) <= set(PATHS):
        raise SystemExit(f"--paths {args.paths!r}: give two or more of {', '.join(PATHS)}")
    every = 1 if args.full else args.every
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        manifest = baked(work, every)
        runs: dict[str, list] = {path: [] for path in paths}
        for k in range(args.repeats):
            for path in paths if k % 2 == 0 else paths[::-1]:
                result = run_path(manifest, path, args.points, Path(tmp))
                runs[path].append(result)
                print(f"{path:9s}", json.dumps(result["figures"]), flush=True)
    first, second = (runs[path][0]["receipts"] for path in paths[:2])
    diff, where = largest_difference(first, second)
    walls = {name: min(r["figures"]["wall_s"] for r in rs) for name, rs in runs.items()}
    doc = {
        "asset": f"{ASSET}, every {every}th sphere ({len(first['materials'])} materials)",
        "points_per_part": args.points,
        "load_average": os.getloadavg(),
        "paths": {name: [r["figures"] for r in rs] for name, rs in runs.items()},
        f"{paths[0]}_over_{paths[1]}_wall": walls[paths[0]] / walls[paths[1]],
        "largest_receipt_difference": {"value": diff, "at": where},
    }
    print(json.dumps({k: v for k, v in doc.items() if k != "paths"}, indent=2))
    if args.json:
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
