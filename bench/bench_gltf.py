"""glTF bakes against the same materials as a scene file: what the glTF source costs on top of the pipeline.

    python bench/bench_gltf.py [--json bench/gltf-result.json] [--materials 6] [--seed 0]

Writes a glTF asset by hand with random films (η2 uniform in 1.0–2.5), fixed thicknesses (50–800 nm) and
dielectric bases (ior 1.0–2.5), and the scene file (TOML) with the same films, thicknesses and bases. Each
is baked from scratch (`lutbake bake --gltf|--scene … --out TMP --json`, a fresh interpreter each, the
order alternated over --repeats) and timed: the bake's own seconds (plan to commit, device start-up
included), the command's wall and CPU seconds. Reported: each path's median and the ratio glTF / TOML of
the medians (the same jobs: only reading and mapping the asset differ), the machine's load average, the
device, and the worst p99 ΔE00 each bake reached.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def write_inputs(folder: Path, n: int, seed: int) -> tuple:
    rng = np.random.default_rng(seed)
    films, thicknesses, iors = rng.uniform(1.0, 2.5, n), rng.uniform(50, 800, n), rng.uniform(1.0, 2.5, n)
    materials = [
        {
            "name": f"film{i}",
            "pbrMetallicRoughness": {"metallicFactor": 0},
            "extensions": {
                "KHR_materials_iridescence": {  # iridescenceFactor defaults to 0: no film
                    "iridescenceFactor": 1.0,
                    "iridescenceIor": float(f),
                    "iridescenceThicknessMaximum": float(d),
                },
                "KHR_materials_ior": {"ior": float(b)},
            },
        }
        for i, (f, d, b) in enumerate(zip(films, thicknesses, iors))
    ]
    doc = {
        "asset": {"version": "2.0"},
        "materials": materials,
        "meshes": [{"primitives": [{"attributes": {}, "material": i}]} for i in range(n)],
    }
    gltf = folder / "random.gltf"
    gltf.write_text(json.dumps(doc))
    toml = folder / "random.toml"
    toml.write_text(
        "".join(
            f"[materials.m{i}-film{i}-dielectric]\nfilm = {float(f)!r}\n"
            f"thickness_nm = {float(d)!r}\nbase = {float(b)!r}\n"
            for i, (f, d, b) in enumerate(zip(films, thicknesses, iors))
        )
    )
    return gltf, toml


def bake(flag: str, path: Path, out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "lutbake.cli",
            "bake",
            flag,
            str(path),
            "--out",
            str(out),
            "--force",
            "--quiet",
            "--json",
        ],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode:
        raise SystemExit(proc.stderr)
    doc = json.loads(proc.stdout)
    manifest = json.loads((out / f"{path.stem}.json").read_text())
    return {
        "seconds": doc["seconds"],
        "wall": wall,
        "cpu": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "device": doc["device"],
        "worst_p99": max(e["de00_p99"] for e in manifest["materials"].values()),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--materials", type=int, default=6)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    runs = {"gltf": [], "toml": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        gltf, toml = write_inputs(tmp, args.materials, args.seed)
        load = os.getloadavg()[0]
        for r in range(args.repeats):
            order = [("gltf", "--gltf", gltf), ("toml", "--scene", toml)]
            for key, flag, path in order if r % 2 == 0 else order[::-1]:
                runs[key].append(bake(flag, path, tmp / f"{key}-{r}"))
    medians = {
        k: {m: statistics.median(row[m] for row in v) for m in ("seconds", "wall", "cpu")} for k, v in runs.items()
    }
    doc = {
        "materials": args.materials,
        "seed": args.seed,
        "repeats": args.repeats,
        "load_average": load,
        "device": runs["gltf"][0]["device"],
        "median": medians,
        "ratio_gltf_over_toml": {m: medians["gltf"][m] / medians["toml"][m] for m in ("seconds", "wall", "cpu")},
        "worst_p99": {k: max(row["worst_p99"] for row in v) for k, v in runs.items()},
        "runs": runs,
    }
    print(
        json.dumps(
            {k: doc[k] for k in ("median", "ratio_gltf_over_toml", "worst_p99", "load_average", "device")}, indent=2
        )
    )
    if args.json:
        args.json.write_text(json.dumps(doc, indent=2) + "\n")


if __name__ == "__main__":
    main()
