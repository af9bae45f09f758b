"""Texture-driven metals of a `lutbake bake --gltf` output served in Babylon.js and PlayCanvas: the baked asset,
its base colour texture, the page's rows and lutbake's model of them, which tests/engines/test_web_gltf_metals.py
and bench/bench_web_engines.py (`metals`) share.

The Khronos asset IridescenceLamp (its materials from tests/fixtures/khronos_iridescence.json on generated
geometry) has two such materials over a dielectric part, mixed by a metalness texture; baked by the CLI with
material 2 forced to the bake (`--route 2=bake`: its metal part is a 4D LUT) and material 1's metal part left
on the runtime table (the bake's own choice). Its base colour texture (nearest filtering) holds random colours
and searched ones: every channel at the F0 table's ends and past them (0, its last node, 1), at and between its
nodes, and at the F0s where the runtime table is worst against the ground truth along the mapping's curve
(bench_gltf_runtime.curve_worst). Both engines load the same asset, baked once, its thickness textures
included (PlayCanvas 2.23.3 with lutbake's fix of its thickness map, engine/lutbake-playcanvas.js
fixIridescenceThicknessMap): each pixel's film is at its textured thickness.
"""

import subprocess
import sys

import numpy as np
from engine_harness import ROOT
from gltf_assets import khronos_document, stand_in
from PIL import Image
from runtime_contract import runtime_table_files
from web_engines import serve_gltf_bake

from lutbake.io.manifest import read_scene_manifest
from lutbake.modes.runtime import read_runtime_table
from lutbake.physics.colorimetry import delta_e00
from lutbake.scene.gltf.materials import METAL_TABLE_NODES

sys.path.insert(0, str(ROOT / "bench"))
import bench_gltf_runtime as bench  # noqa: E402  (the film term the plugins serve at a pixel, and its truth)

ASSET = "IridescenceLamp"
ROUTES = {
    "bake": {1: {"dielectric": "slice", "metal": "runtime"}, 2: {"dielectric": "slice", "metal": "lut"}},
    "runtime": {1: {"dielectric": "runtime", "metal": "runtime"}, 2: {"dielectric": "runtime", "metal": "runtime"}},
}
TRUTH_PIXELS = 120  # per material and serve: the ground truth of a coloured metal costs ~10 ms a point
NEAREST = 9728


def _srgb_bytes(linear: np.ndarray) -> np.ndarray:
    """Linear colours as the 8-bit sRGB a glTF base colour texture stores."""
    encoded = np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * np.power(linear, 1 / 2.4) - 0.055)
    return np.clip(np.round(255 * encoded), 0, 255).astype(np.uint8)


def _base_colours(f0_max: float, nodes: int) -> np.ndarray:
    """256 linear base colours, 8 columns x 32 rows: random, and in the middle rows (away from the sphere's
    poles, where texels shrink) every combination of the table's ends and past them per channel, the F0
    table's first nodes and the points between them, and the searched F0s."""
    rng = np.random.default_rng(41)
    ends = np.array(np.meshgrid(*[[0.0, f0_max, 1.0]] * 3)).reshape(3, -1).T
    grid = np.linspace(0.0, f0_max, nodes)
    along = np.concatenate([grid[1:9], 0.5 * (grid[:8] + grid[1:9])])
    worst = bench.curve_worst(budget=400, seed=3)
    searched = np.array([c.where[3] * f0_max for c in worst.candidates[:16]])
    singles = rng.permutation(np.concatenate([along, searched]))
    picked = np.stack([singles, rng.permutation(singles), rng.permutation(singles)], -1)
    colours = rng.uniform(0, 1, (256, 3))
    colours[96 : 96 + len(ends) + len(picked)] = np.concatenate([ends, picked])  # rows 12-19
    return colours.reshape(32, 8, 3)


def _write_base_colour(folder, doc, f0_max) -> None:
    """The stand-in's base colour image (the materials' baseColorTexture), repeated 4 times along u so that
    the half of the sphere the camera sees holds every colour."""
    image = doc["textures"][doc["materials"][2]["pbrMetallicRoughness"]["baseColorTexture"]["index"]]["source"]
    texels = np.tile(_srgb_bytes(_base_colours(f0_max, METAL_TABLE_NODES)), (1, 4, 1))
    Image.fromarray(texels).save(folder / f"{ASSET}-image{image}.png")


def _bake(doc, folder):
    """The asset's stand-in baked by `lutbake bake --gltf --route 2=bake` into FOLDER (the forced LUT may
    miss the scene's target: written, exit code 1): (glTF, out, manifest)."""
    gltf = stand_in(doc, folder, ASSET)
    out = folder / "out"
    cli = [sys.executable, "-m", "lutbake", "bake", "--gltf", str(gltf), "--out", str(out), "--route", "2=bake"]
    proc = subprocess.run(cli, capture_output=True, text=True, cwd=ROOT, timeout=600)
    written = proc.returncode == 1 and "(written;" in proc.stderr  # the forced LUT may miss the target: exit 1
    assert proc.returncode == 0 or written, proc.stderr[-2000:]
    manifest = read_scene_manifest(out / f"{ASSET}.json")  # metal tables in place (the manifest names them)
    metal = next(r for r in manifest["source"]["materials"] if r["gltf_index"] == 2)["parts"]["metal"]
    _write_base_colour(folder, doc, max(metal["f0_max"]))  # the F0 table's last node
    return gltf, out, manifest


def bake_for_engines(folder, engines) -> dict:
    """The asset baked once into FOLDER (one the harness serves, inside the repository), every texture read
    with nearest filtering, the same bake for each engine: {engine: (glTF, out, manifest)}."""
    doc = khronos_document(ASSET)
    doc["samplers"] = [{"magFilter": NEAREST, "minFilter": NEAREST}]
    baked = _bake(doc, folder)
    return dict.fromkeys(engines, baked)


def serve_metals(engine, baked, serve, folder, size=64):
    """The engine's render of both materials, served by ``serve`` (bake or runtime), every other pixel of a
    ``size``² render: (cells, manifest, out, runtime table, {glTF index: rows in bench_gltf_runtime's columns})."""
    gltf, out, manifest = baked
    folder.mkdir(parents=True, exist_ok=True)
    cells = serve_gltf_bake(engine, gltf, out / f"{ASSET}.json", serve, folder, size=size)
    rows = {cell["lutbake"]["gltfIndex"]: _rows(np.array(cell["samples"], float)) for cell in cells}
    return cells, manifest, out, read_runtime_table(runtime_table_files()), rows


def _rows(samples: np.ndarray) -> np.ndarray:
    """The page's samples [rgb, cos θ, thickness, film, base rgb, metallic] in bench_gltf_runtime's columns
    (rgb 0-2, cos θ 3, thickness 4, metalness 5, base colour 7-9)."""
    rgb, cos, thickness, base, metallic = samples[:, :3], samples[:, 3], samples[:, 4], samples[:, 6:9], samples[:, 9]
    return np.column_stack([rgb, cos, thickness, metallic, np.zeros(len(samples)), base])


def metal_model(serve, record, manifest, out, table, rows):
    """lutbake's model of the term the engine serves at each row."""
    if serve == "runtime":
        return bench.runtime_term(record, table, rows)
    return bench.baked_term(record, manifest, out, rows, table)


def truth_errors(serve, record, manifest, out, table, rows, index):
    """ΔE00 against the spectral ground truth at TRUTH_PIXELS of the rows (picked by the material's glTF
    index) of the engine's term and of lutbake's model of it: (engine's, model's)."""
    pick = np.random.default_rng(index).choice(len(rows), min(TRUTH_PIXELS, len(rows)), replace=False)
    truth = bench.film_truth(record, rows[pick])
    model = metal_model(serve, record, manifest, out, table, rows[pick])
    return delta_e00(rows[pick, :3], truth), delta_e00(model, truth)
