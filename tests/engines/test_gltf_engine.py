"""glTF bakes of the Khronos showcase assets' materials (tests/fixtures/khronos_iridescence.json, on generated
spheres and gradient textures) and of generated assets: every slice and 4D LUT holds its material's ground truth, and
the three.js GLTFLoader plugin (engine/lutbake-gltf.js) in headless Chromium computes, at every pixel, the
film term lutbake's samplers return for that pixel's cos θ, thickness, metalness and base colour, to 1e-4."""

import shutil
import sys
import uuid

import numpy as np
import pytest
from engine_harness import ROOT, require_engine, run_harness
from gltf_assets import SHOWCASE, document, iridescent, khronos_document, stand_in

from lutbake.io.manifest import read_scene_manifest  # metal tables in place (the manifest names them)
from lutbake.lut.sample import Atlas, Lut
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.scene.bake import bake_scene
from lutbake.scene.gltf.materials import load_gltf_scene
from lutbake.spectral.reference import reference_colour

sys.path.insert(0, str(ROOT / "bench"))
from bench_gltf_runtime import baked_term, runtime_stem  # noqa: E402  (the film term the plugin serves at a pixel)
from runtime_contract import runtime_table_files  # noqa: E402

from lutbake.modes.runtime import read_runtime_table  # noqa: E402

TOLERANCE = 1e-4


def _generated() -> dict:
    """A hand-written asset: dielectrics with fixed and textured thickness, a coloured metal (a slice per
    channel), a texture-driven coloured metal (4D LUT) and a half-metal mixing both parts."""
    textured_metal = iridescent(
        ior=1.45, d_min=150, d_max=450, thickness_texture=True, metallic=1.0, colour=[0.95, 0.64, 0.54]
    )
    textured_metal["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    mixed = iridescent(ior=1.7, d_max=300, base_ior=1.9, metallic=1.0, colour=[0.5, 0.5, 0.5])
    mixed["pbrMetallicRoughness"]["metallicRoughnessTexture"] = {"index": 0}
    return document(
        [
            iridescent(ior=1.33, d_max=380, base_ior=1.0),
            iridescent(ior=2.2, d_min=100, d_max=700, thickness_texture=True, base_ior=1.5),
            iridescent(ior=1.6, d_max=250, metallic=1.0, colour=[0.9, 0.6, 0.3]),
            textured_metal,
            mixed,
        ],
        textures=[{"source": 0}],
    )


@pytest.fixture(scope="module")
def bakes():
    """Every asset's stand-in (gltf_assets.stand_in), baked by `bake --gltf`'s library call into a folder the
    harness serves (repository files): {asset: (glTF path, manifest, output folder)}."""
    folder = ROOT / "build" / f"gltf-engine-{uuid.uuid4().hex[:8]}"
    try:
        sources = {**{name: khronos_document(name) for name in SHOWCASE}, "generated": _generated()}
        out = {}
        for name, doc in sources.items():
            gltf = stand_in(doc, folder / name, name)
            result = bake_scene(load_gltf_scene(gltf), folder / name / "out")
            assert result.unmet == {}, (name, result.unmet)
            out[name] = (gltf, read_scene_manifest(folder / name / "out" / f"{name}.json"), folder / name / "out")
        yield out
    finally:
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def plugin_run(bakes, tmp_path_factory):
    """One Chromium run over every asset, the runtime table given for the parts the bake routed to it:
    {asset: (manifest, folder, {glTF material index: samples})}."""
    require_engine()
    runtime = runtime_stem()
    specs = [
        {
            "gltf": f"/{gltf.relative_to(ROOT)}",
            "manifest": f"/{(out / f'{name}.json').relative_to(ROOT)}",
            "runtime": runtime,
        }
        for name, (gltf, _, out) in bakes.items()
    ]
    results = run_harness("gltf", tmp_path_factory.mktemp("plugin"), specs)["results"]
    return {name: (manifest, out, got) for (name, (_, manifest, out)), got in zip(bakes.items(), results)}


def test_showcase_slices_and_luts_hold_their_materials_ground_truth(bakes):
    """Every slice (`sample --material`'s name) returns its material's ground truth at 1,000 fresh points
    within the scene's target (p99 ΔE00 ≤ max_de, no allowance: the bake holds `report`'s p99 at any seed,
    lutbake/scene/jobs.py), and every texture-driven metal's 4D LUT does where the engine reads it: along the
    mapping's F0 → (η3, κ3) table."""
    rng = np.random.default_rng(23)  # not a seed the bake scored at
    for name, (_, manifest, out) in bakes.items():
        tables = {
            r["parts"]["metal"]["channels"][0]: r["parts"]["metal"]["table"]
            for r in manifest["source"]["materials"]
            if r["parts"].get("metal", {}).get("texture")
        }
        for material, entry in manifest["materials"].items():
            cos_t, u = rng.uniform(0, 1, 1000) ** 2, rng.uniform(0, 1, 1000)
            if entry["kind"] == "slice":
                atlas = Atlas.load(out / entry["file"])
                lo, hi = entry["axes"]["thickness_nm"]["min"], entry["axes"]["thickness_nm"]["max"]
                pts = FilmPoints.build(**atlas.film_stack(material), cos_theta=cos_t, thickness_nm=lo + u * (hi - lo))
                rgb = atlas.sample(material, pts)
            else:
                lut, table = Lut.load(out / entry["file"]), tables[material]
                f0 = rng.uniform(0, table["f0"][-1], 1000)
                pts = FilmPoints.build(
                    eta2=lut.eta2,
                    cos_theta=cos_t,
                    opd_nm=lut.axes[1].lo + u * (lut.axes[1].hi - lut.axes[1].lo),
                    eta3=np.interp(f0, table["f0"], table["eta3"]),
                    kappa3=np.interp(f0, table["f0"], table["kappa3"]),
                )
                rgb = lut.sample(pts)
            p99 = np.percentile(delta_e00(rgb, reference_colour(pts).values), 99)
            assert p99 <= manifest["settings"]["max_de"], (name, material, p99)


@pytest.mark.parametrize("asset", SHOWCASE + ["generated"])
def test_plugin_film_term_equals_lutbake_sample(plugin_run, asset):
    manifest, folder, result = plugin_run[asset]
    records = {r["gltf_index"]: r for r in manifest["source"]["materials"] if r["parts"]}
    assert sorted(map(int, result)) == sorted(records)  # every baked material was patched
    table = read_runtime_table(runtime_table_files())
    for index, samples in result.items():
        assert len(samples) > 100, (asset, index)
        rows = np.array(samples)
        error = np.abs(rows[:, :3] - baked_term(records[int(index)], manifest, folder, rows, table)).max()
        assert error <= TOLERANCE, (asset, index, error)


def test_the_check_can_fail(plugin_run):
    """The generated coloured metal read with every channel from the red channel's slice is far off: the
    comparison above tells slices apart."""
    manifest, folder, result = plugin_run["generated"]
    record = next(r for r in manifest["source"]["materials"] if r["gltf_index"] == 2)
    wrong = {
        **record,
        "parts": {"metal": {**record["parts"]["metal"], "channels": [record["parts"]["metal"]["channels"][0]] * 3}},
    }
    rows = np.array(result["2"])
    assert np.abs(rows[:, :3] - baked_term(wrong, manifest, folder, rows)).max() > 100 * TOLERANCE
    metalness = {round(s[5], 6) for s in result["4"]}
    assert len(metalness) > 10  # the half-metal's metalness varies over the sphere: both parts are exercised
