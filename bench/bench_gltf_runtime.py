"""A glTF scene baked or served by the runtime table: error, bytes on the GPU and cost, in one three.js run.

    python bench/bench_gltf_runtime.py [--json bench/gltf-runtime-result.json]
    python bench/bench_gltf_runtime.py --first-frame 5 [--json bench/gltf-first-frame-result.json]

The Khronos showcase assets' materials (tests/fixtures/khronos_iridescence.json, on generated spheres and
gradient textures: tests/gltf_assets.stand_in) are baked (`bake --gltf`'s library call, timed), then three.js
r187 in headless Chromium renders every iridescent material twice through lutbake's GLTFLoader plugin: served by
the bake (atlas slices, 4D LUTs) and by the runtime table (`serve: 'runtime'`). At PIXELS pixels per material (a
seeded choice among those the sphere covers) both film terms are scored against the spectral ground truth at the
parameters that pixel used (cos θ, thickness, metalness, base colour through the bake's metal mapping):
ΔE00 p99 and the largest over those pixels, per material and pooled. Bytes on the GPU: every texture as
EXRLoader uploads it (RGBA half, 8 bytes a texel; the runtime table's from lutbake report's table). Reads and
SPIR-V arithmetic per pixel: lutbake report's table (lutbake/modes/runtime/costs.py). And a searched maximum
of the runtime table along the whole fitted metal curve the plugin reads for texture-driven metals
(curve_worst), which the pixels sample only in part. And the first frame of a 49-material sphere grid
(IridescenceMetallicSpheres' 100 nm block, one sphere per material) through the plugin, baked and from the
runtime table, as a ratio to stock three.js's own iridescence drawing the same grid in the same page, with
each one's renderer.info.programs (first_frames; `--first-frame ROUNDS` runs only that).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "docs"))

from gltf_assets import SHOWCASE, khronos_document, stand_in  # noqa: E402
from make_dropin import write_runtime_table  # noqa: E402

from lutbake.io.manifest import read_scene_manifest  # noqa: E402
from lutbake.physics.colorimetry import delta_e00  # noqa: E402
from lutbake.quality.runtime_accuracy import truth  # noqa: E402
from lutbake.tables.headers import check_structure, exr_header  # noqa: E402

PIXELS = 150  # scored per material: the ground truth costs ~3 ms a point, ~10 for a coloured metal
SIZE, STRIDE = 64, 3  # rendered square, and every STRIDE-th pixel returned
SERVES = ("bake", "runtime")
GPU_TEXEL_BYTES = 8  # EXRLoader's default upload: RGBA half
CURVE_BUDGET = 2000  # evaluations of the search along the metal mapping's curve (curve_worst)
GRID, GRID_MATERIALS = "IridescenceMetallicSpheres", 49  # its 100 nm block: 7 grey bases x 7 film indices
GRID_SERVES = ("three", "bake", "runtime")  # stock three.js's own iridescence, then lutbake's plugin
FIRST_FRAME_ROUNDS = 5  # fresh Chromium runs of the grid's first frame (first_frames)


def bake_stand_in(doc: dict, folder: Path, name: str) -> dict:
    """The stand-in of glTF document DOC baked into FOLDER/NAME/out: {gltf, manifest, out, bake_s}."""
    from lutbake.scene.bake import bake_scene
    from lutbake.scene.gltf.materials import load_gltf_scene

    gltf = stand_in(doc, folder / name, name)
    start = time.perf_counter()
    result = bake_scene(load_gltf_scene(gltf), folder / name / "out")
    if result.unmet:
        raise RuntimeError(f"{name}: the bake missed its target: {result.unmet}")
    return {
        "gltf": gltf,
        "manifest": read_scene_manifest(folder / name / "out" / f"{name}.json"),  # metal tables in place
        "out": folder / name / "out",
        "bake_s": time.perf_counter() - start,
    }


def bake_stand_ins(folder: Path, names=SHOWCASE) -> dict:
    """Each asset's stand-in baked into FOLDER/NAME/out: {asset: {gltf, manifest, out, bake_s}}."""
    folder.mkdir(parents=True, exist_ok=True)
    return {name: bake_stand_in(khronos_document(name), folder, name) for name in names}


def bake_grid(folder: Path) -> dict:
    """The sphere grid (GRID's first GRID_MATERIALS materials: one thickness, every base colour under every
    film index, each sphere its own glTF material) baked as bake_stand_in does."""
    doc = khronos_document(GRID)
    doc["materials"] = doc["materials"][:GRID_MATERIALS]
    return bake_stand_in(doc, folder, "grid")


def url(path: Path) -> str:
    """A repository file as the harness serves it."""
    return f"/{path.relative_to(ROOT)}"


def runtime_stem() -> str:
    return url(write_runtime_table().with_suffix(""))


def render(specs, command: str = "gltf") -> dict:
    """engine/harness.mjs COMMAND in one Chromium run: gltf over every spec ({gltf, manifest|plan, runtime,
    serves}), gltf-grid over one (engine/gltf-page.js, lutbakeGltfGrid)."""
    with tempfile.TemporaryDirectory() as tmp:
        spec, result = Path(tmp) / "spec.json", Path(tmp) / "result.json"
        spec.write_text(json.dumps(specs))
        proc = subprocess.run(
            ["node", str(ROOT / "engine" / "harness.mjs"), command, str(spec), str(result)],
            capture_output=True,
            text=True,
            cwd=ROOT,
            timeout=600,
        )
        if proc.returncode:
            raise RuntimeError(proc.stderr[-4000:])
        return json.loads(result.read_text())


def both_serves(bakes: dict) -> list:
    """One spec per asset: its bake, and the runtime table for the second serve."""
    return [
        {
            "gltf": url(b["gltf"]),
            "manifest": url(b["out"] / f"{name}.json"),
            "runtime": runtime_stem(),
            "serves": list(SERVES),
            "size": SIZE,
            "stride": STRIDE,
        }
        for name, b in bakes.items()
    ]


def part_bases(part: dict, colour: np.ndarray) -> tuple:
    """(η3, κ3), (n, 3) each, of a part at n pixels' base colours: the dielectric's index, a metal's per
    channel, or a texture-driven metal's through its F0 table as the plugin reads it (clamped at its ends)."""
    n = len(colour)
    if "base" in part:
        return np.full((n, 3), part["base"][0]), np.full((n, 3), part["base"][1])
    if "table" in part:
        table = part["table"]
        return np.interp(colour, table["f0"], table["eta3"]), np.interp(colour, table["f0"], table["kappa3"])
    return np.tile(part["eta3"], (n, 1)), np.tile(part["kappa3"], (n, 1))


def film_truth(record: dict, rows: np.ndarray, film=None) -> np.ndarray:
    """The ground truth of the film term at each row's parameters: (1 − m)·dielectric + m·metal, each part
    integrated only where its weight is non-zero. ``film`` replaces the record's η2 (the check that fails)."""
    cos, thickness, metalness, colour = rows[:, 3], rows[:, 4], rows[:, 5], rows[:, 7:10]
    eta2 = record["film"] if film is None else film
    out = np.zeros((len(rows), 3))
    for name, part in record["parts"].items():
        weight = 1.0 - metalness if name == "dielectric" else metalness
        at = weight > 0
        eta3, kappa3 = part_bases(part, colour[at])
        out[at] += weight[at, None] * truth(cos[at], thickness[at], eta2, eta3, kappa3)
    return out


def _table(path: Path):
    """An atlas or LUT of a bake, read once per process."""
    from lutbake.lut.sample import load_table

    if path not in _TABLES:
        _TABLES[path] = load_table(path)
    return _TABLES[path]


_TABLES: dict = {}


def _mix(record: dict, rows: np.ndarray, term) -> np.ndarray:
    """(1 − m)·dielectric + m·metal at each row's metalness (column 5), each part's term(part) (n, 3)."""
    out = np.zeros((len(rows), 3))
    for name, part in record["parts"].items():
        out += (1.0 - rows[:, 5] if name == "dielectric" else rows[:, 5])[:, None] * term(part)
    return out


def _runtime_part(record: dict, part: dict, table, rows: np.ndarray) -> np.ndarray:
    """One part's film term from the runtime table's include (runtime.model): its constant, one base index,
    or one per channel (a texture-driven metal's through its F0 table at the row's base colour)."""
    from lutbake.modes.runtime import runtime_colour

    cos, thickness, colour = rows[:, 3], rows[:, 4], rows[:, 7:10]
    if "constant" in part:
        return np.tile(part["constant"], (len(rows), 1))
    bases = part["base"] if "base" in part else part_bases(part, colour)
    return runtime_colour(table, cos, thickness, 1.0, record["film"], *bases)


def _baked_part(part: dict, manifest: dict, folder: Path, rows: np.ndarray) -> np.ndarray:
    """One part's film term from the bake: its slice, a slice per channel, or its 4D LUT read per channel at
    the base its F0 table maps the row's colour to."""
    from lutbake.physics.points import FilmPoints

    cos, thickness, colour = rows[:, 3], rows[:, 4], rows[:, 7:10]
    names = [part["material"]] if "material" in part else part["channels"]
    table = _table(folder / manifest["materials"][names[0]]["file"])
    if manifest["materials"][names[0]]["kind"] == "slice":
        reads = [
            table.sample(n, FilmPoints.build(**table.film_stack(n), cos_theta=cos, thickness_nm=thickness))
            for n in names
        ]
        return reads[0] if len(reads) == 1 else np.stack([reads[c][:, c] for c in range(3)], axis=1)
    eta3, kappa3 = part_bases(part, colour)
    pts = FilmPoints.build(
        eta2=table.eta2, cos_theta=cos[:, None], thickness_nm=thickness[:, None], eta3=eta3, kappa3=kappa3
    )
    return np.diagonal(table.sample(pts), axis1=1, axis2=2)


def baked_term(record: dict, manifest: dict, folder: Path, rows: np.ndarray, runtime=None) -> np.ndarray:
    """The film term the plugin serves from a bake at each row's parameters (its columns: cos θ 3, thickness
    4, metalness 5, base colour 7-9), mixed by metalness: each part its constant, its slice(s) or 4D LUT
    (lutbake's samplers), or, where the bake does not cover it (routed to the runtime table), the RUNTIME
    table's include."""

    def term(part: dict) -> np.ndarray:
        entry = manifest["materials"].get(part.get("material") or part.get("channels", [None])[0])
        if "constant" in part or entry is None or entry["kind"] == "runtime":
            return _runtime_part(record, part, runtime, rows)
        return _baked_part(part, manifest, folder, rows)

    return _mix(record, rows, term)


def runtime_term(record: dict, table, rows: np.ndarray) -> np.ndarray:
    """The film term the runtime table's include gives at each row's parameters, mixed by metalness."""
    return _mix(record, rows, lambda part: _runtime_part(record, part, table, rows))


def grid_spec(grid: dict, serves=GRID_SERVES, precision=None, samples: bool = True, cell: int = 20) -> dict:
    """engine/gltf-page.js lutbakeGltfGrid's spec for the baked grid (bake_grid), the runtime table beside."""
    return {
        "gltf": url(grid["gltf"]),
        "manifest": url(grid["out"] / "grid.json"),
        "runtime": runtime_stem(),
        "precision": precision,
        "serves": list(serves),
        "columns": 7,
        "cell": cell,
        "stride": 1,
        "samples": samples,
    }


def first_frames(grid: dict, rounds: int) -> dict:
    """The grid's first frame (compile, upload, draw, read back) in ROUNDS fresh Chromium runs, the serves in
    a rotated order each round: each serve's milliseconds and programs, its ratio to stock three.js's frame
    in the same page each round, and their median."""
    runs = []
    for k in range(rounds):
        serves = GRID_SERVES[k % 3 :] + GRID_SERVES[: k % 3]
        runs.append(render(grid_spec(grid, serves, samples=False, cell=32), command="gltf-grid"))
    frames = {}
    for serve in GRID_SERVES:
        ratios = [r[serve]["first_frame_ms"] / r["three"]["first_frame_ms"] for r in runs]
        frames[serve] = {
            "first_frame_ms": [round(r[serve]["first_frame_ms"], 1) for r in runs],
            "programs": runs[0][serve]["programs"],
            "ratios_to_three": [round(x, 2) for x in ratios],
            "ratio_to_three": float(np.median(ratios)),
        }
    return {
        "materials": GRID_MATERIALS,
        "rounds": rounds,
        "serves": frames,
        "precision": runs[0]["runtime"]["precision"],
    }


def score(result: dict, bakes: dict, seed: int = 7) -> dict:
    """{asset: {glTF material index: {serve: ΔE00 (PIXELS,)}, 'rows': the pixels scored}} from one run."""
    rng = np.random.default_rng(seed)
    out = {}
    for (name, bake), materials in zip(bakes.items(), result["results"]):
        records = {r["gltf_index"]: r for r in bake["manifest"]["source"]["materials"]}
        out[name] = {}
        for index, samples in materials.items():
            rows = np.array(samples)
            rows = rows[np.sort(rng.choice(len(rows), min(PIXELS, len(rows)), replace=False))]
            reference = film_truth(records[int(index)], rows)
            out[name][int(index)] = {
                "rows": rows,
                "truth": reference,
                **{
                    serve: delta_e00(rows[:, cols], reference)
                    for serve, cols in zip(SERVES, (slice(0, 3), slice(10, 13)))
                },
            }
    return out


def curve_worst(budget: int, seed: int = 0):
    """The runtime table along the fitted metal mapping's whole curve, as the plugin reads it for a
    texture-driven metal: worstcase.find_worst over (cos θ, d 0–1500 nm, η2 1–3, F0 0–0.99), the base
    (η3, κ3) interpolated in the 65-node F0 table the manifest carries, one F0 for all channels (each
    channel is the film over its own base). runtime.model is what three.js returns to 1e-4
    (tests/engines/test_runtime_engine.py). The curve's white end leaves the table's searched metal box (η3 < 0.05
    above F0 0.97) and its dark end the metal box for the dielectric one (κ3 < 1.5)."""
    from lutbake.modes.runtime import read_runtime_table, runtime_colour
    from lutbake.physics.metals import F0_MAX, conductor
    from lutbake.quality.worstcase import SearchAxis, find_worst
    from lutbake.scene.gltf.materials import METAL_TABLE_NODES

    table = read_runtime_table(write_runtime_table())
    nodes = np.linspace(0.0, F0_MAX["fitted"], METAL_TABLE_NODES)
    eta_nodes, kappa_nodes, _ = conductor(nodes, "fitted")

    def error(unit):
        cos, d, eta2 = (np.float32(c).astype(float) for c in (unit[:, 0], 1500.0 * unit[:, 1], 1.0 + 2.0 * unit[:, 2]))
        f0 = F0_MAX["fitted"] * unit[:, 3]
        eta3, kappa3 = np.interp(f0, nodes, eta_nodes), np.interp(f0, nodes, kappa_nodes)
        de = delta_e00(runtime_colour(table, cos, d, 1.0, eta2, eta3, kappa3), truth(cos, d, eta2, eta3, kappa3))
        return np.where(np.isfinite(de), de, np.inf)

    axes = (
        SearchAxis("cos_theta", cells=16),
        SearchAxis("thickness_nm", cells=32),
        SearchAxis("eta2", cells=16),
        SearchAxis("f0", cells=METAL_TABLE_NODES - 1),
    )
    return find_worst(
        error,
        axes,
        singular={
            "grazing": {"cos_theta": 0.0},
            "no film": {"thickness_nm": 0.0},
            "film = ambient": {"eta2": 0.0},
            "black": {"f0": 0.0},
        },
        budget=budget,
        seed=seed,
    )


def gpu_bytes(bake: dict) -> int:
    """Bytes of every texture the bake binds (atlas, 4D LUTs) as EXRLoader uploads them."""
    files = {entry["file"] for entry in bake["manifest"]["materials"].values()}
    shapes = [check_structure(exr_header(bake["out"] / f)) for f in files]
    return sum(s["width"] * s["height"] * GPU_TEXEL_BYTES for s in shapes)


def summary(bakes: dict, scores: dict) -> dict:
    from lutbake.modes.runtime.costs import path_costs

    costs = path_costs()["paths"]
    rows = []
    for name, materials in scores.items():
        for index, s in materials.items():
            record = next(r for r in bakes[name]["manifest"]["source"]["materials"] if r["gltf_index"] == index)
            rows.append(
                {
                    "asset": name,
                    "gltf_index": index,
                    "name": record["name"],
                    "film": record["film"],
                    "parts": {p: ("texture" if v.get("texture") else "constant") for p, v in record["parts"].items()},
                    **{
                        f"{serve}_{k}": float(f(s[serve]))
                        for serve in SERVES
                        for k, f in (("p99", lambda d: np.percentile(d, 99)), ("max", np.max))
                    },
                }
            )
    pooled = {serve: np.concatenate([s[serve] for m in scores.values() for s in m.values()]) for serve in SERVES}
    return {
        "materials": rows,
        "pixels_per_material": PIXELS,
        "pooled": {
            serve: {"p99": float(np.percentile(d, 99)), "max": float(d.max()), "n": int(d.size)}
            for serve, d in pooled.items()
        },
        "gpu_bytes": {"bake": {n: gpu_bytes(b) for n, b in bakes.items()}, "runtime": costs["runtime"]["gpu_bytes"]},
        "bake_s": {n: round(b["bake_s"], 2) for n, b in bakes.items()},
        "per_pixel": {k: costs[k] for k in ("runtime", "runtime-rgb", "lut-cubic-rgb")},
        "load_average": os.getloadavg(),
    }


def first_frame_main(rounds: int, path: Path) -> None:
    """--first-frame: the sphere grid's first frame only (first_frames), written to PATH and printed."""
    folder = ROOT / "build" / f"bench-gltf-grid-{os.getpid()}"
    try:
        doc = {**first_frames(bake_grid(folder), rounds), "load_average": os.getloadavg()}
    finally:
        subprocess.run(["rm", "-rf", str(folder)], check=False)
    path.write_text(json.dumps(doc, indent=1) + "\n")
    print(json.dumps(doc, indent=1))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--json", type=Path, default=None, help="where the result goes (default: bench/...-result.json)"
    )
    parser.add_argument("--first-frame", type=int, metavar="ROUNDS", default=0, help="only the grid's first frame")
    args = parser.parse_args()
    if args.first_frame:
        return first_frame_main(args.first_frame, args.json or ROOT / "bench" / "gltf-first-frame-result.json")
    folder = ROOT / "build" / f"bench-gltf-runtime-{os.getpid()}"
    try:
        bakes = bake_stand_ins(folder)
        result = render(both_serves(bakes))
        doc = {
            "renderer": result["renderer"],
            "three": result["three"],
            **summary(bakes, score(result, bakes)),
            "metal_curve_worst": curve_worst(CURVE_BUDGET).describe(),
            "first_frame": first_frames(bake_grid(folder), FIRST_FRAME_ROUNDS),
        }
    finally:
        subprocess.run(["rm", "-rf", str(folder)], check=False)
    (args.json or ROOT / "bench" / "gltf-runtime-result.json").write_text(json.dumps(doc, indent=1) + "\n")
    print("| asset | glTF material | film | parts | baked p99 / max | runtime p99 / max |\n|---|---|---|---|---|---|")
    for r in doc["materials"]:
        print(
            f"| {r['asset']} | {r['gltf_index']} {r['name']} | {r['film']} | "
            f"{', '.join(f'{p} ({k})' for p, k in r['parts'].items())} | "
            f"{r['bake_p99']:.2f} / {r['bake_max']:.2f} | {r['runtime_p99']:.3f} / {r['runtime_max']:.3f} |"
        )
    worst = {k: v for k, v in doc["metal_curve_worst"].items() if k != "starts"}
    print(
        json.dumps(
            {
                **{k: doc[k] for k in ("pooled", "gpu_bytes", "bake_s", "load_average", "first_frame")},
                "metal_curve_worst": worst,
            },
            indent=1,
        )
    )


if __name__ == "__main__":
    main()
