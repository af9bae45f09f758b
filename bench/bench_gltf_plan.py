"""`lutbake plan`'s time estimate against the bake it estimates, on the Khronos showcase assets and the 343-sphere
grid (rebuilt from tests/fixtures/khronos_iridescence.json by tests/gltf_assets.py: materials as the assets write
them, no geometry).

    python bench/bench_gltf_plan.py [--json bench/gltf-plan-result.json] [--assets NAME ...]

For each asset, in one run: `lutbake plan --gltf ASSET --json` (its ``estimate_seconds``: what `plan` prints as
the bake's time) and then `lutbake bake --gltf ASSET --out TMP --json` from scratch (its own ``seconds``), each
in a fresh interpreter; reported per asset: the estimate, the bake's seconds, their ratio (bake / estimate:
within [0.5, 2] is the goal), the jobs, and the machine's load average before the bake. The two run back to
back on the same machine, so the ratio holds under the same load; absolute seconds are for a quiet machine.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from gltf_assets import SHOWCASE, khronos_gltf  # noqa: E402 - the tests' asset builder

GRID = "IridescenceMetallicSpheres"


def lutbake(*args: object) -> dict:
    proc = subprocess.run(
        [sys.executable, "-m", "lutbake.cli", *map(str, args), "--json"], capture_output=True, text=True, cwd=ROOT
    )
    if proc.returncode not in (0, 1):  # 1: a target not met, still a bake
        raise SystemExit(f"lutbake {' '.join(map(str, args))}: exit {proc.returncode}: {proc.stderr.strip()}")
    return json.loads(proc.stdout)


def measure(name: str, folder: Path) -> dict:
    gltf = khronos_gltf(name, folder / "assets")
    plan = lutbake("plan", "--gltf", gltf)
    load = os.getloadavg()[0]
    bake = lutbake("bake", "--gltf", gltf, "--out", folder / name)
    estimate = plan["estimate_seconds"]
    return {
        "asset": name,
        "jobs": {kind: sum(j["kind"] == kind for j in plan["jobs"]) for kind in ("slice", "lut")},
        "estimate_s": estimate,
        "bake_s": bake["seconds"],
        "ratio": bake["seconds"] / estimate if estimate else None,
        "load_average": load,
        "device": bake["device"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--assets", nargs="*", default=[*SHOWCASE, GRID])
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.assets:
            rows.append(measure(name, Path(tmp)))
            r = rows[-1]
            print(
                f"| {name} | {r['jobs']['slice']} + {r['jobs']['lut']} | {r['estimate_s']:.1f} | {r['bake_s']:.1f} | "
                f"{r['ratio']:.2f} | {r['load_average']:.1f} |",
                flush=True,
            )
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "cpu_count": os.cpu_count()}, indent=2) + "\n")


if __name__ == "__main__":
    main()
