"""glTF as a scene source (issue 23): the Khronos showcase assets plan and bake, the mapping rules hold,
hand-written assets with random films bake, the metal mappings are what they claim."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gltf_assets import (
    KHRONOS,
    SHOWCASE,
    SPHERE_GRIDS,
    credit_line,
    document,
    glb_bytes,
    iridescent,
    khronos_gltf,
    write_gltf,
)

from lutbake.lut.sample import Atlas
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.metals import F0_MAX, conductor, conductor_reflectance, gltf_metal_reflectance, reflectance_error
from lutbake.physics.points import FilmPoints
from lutbake.scene.bake import bake_scene
from lutbake.scene.gltf.materials import load_gltf_scene, material_rows
from lutbake.scene.plan import plan_scene
from lutbake.spectral.reference import reference_colour


def cli(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "lutbake.cli", *map(str, args)], capture_output=True, text=True, cwd=cwd
    )


def test_every_showcase_asset_plans_with_a_slice_per_used_iridescent_material(tmp_path):
    served = 0
    for path in (khronos_gltf(name, tmp_path) for name in SHOWCASE):
        proc = cli("plan", "--gltf", path, "--json")
        assert proc.returncode == 0, proc.stderr
        rows = json.loads(proc.stdout)["gltf_materials"]
        doc = json.loads(path.read_text())
        iridescent_indices = [
            i for i, m in enumerate(doc["materials"]) if "KHR_materials_iridescence" in m.get("extensions", {})
        ]
        assert [r["gltf_index"] for r in rows] == iridescent_indices
        for r in rows:
            assert (r["slice"] or r["lut"]) if r["used_by"] else r["why_not"], (path.name, r)
            served += bool(r["slice"] or r["lut"])
    assert served == 12  # Compare 1, Abalone 1, Lamp 2, Suzanne 3, Dish 2, Sunglasses 1, CarConcept 2 (variants)


def test_materials_used_only_through_variants_are_baked_and_say_which_variant(tmp_path):
    scene = load_gltf_scene(khronos_gltf("CarConcept", tmp_path))
    rows = {r["gltf_index"]: r for r in material_rows(scene, plan_scene(scene))}
    assert rows[22]["used_by"] == ["Pearly Swirly"] and rows[25]["used_by"] == ["Torched Graphite"]
    assert rows[22]["film"] == 1.2 and rows[22]["thickness_nm"] == [820.0, 920.0]  # thickness texture: the range
    assert rows[25]["film"] == 1 and rows[25]["thickness_nm"] == [1000.0, 1000.0]  # no texture: the maximum


def test_sample_by_slice_name_from_the_command_line(tmp_path):
    """`sample ATLAS --material SLICE` (the name plan --json gives) returns the ground truth of that
    glTF material's film over its base (Sunglasses' lens: film 2.0, 300.01 nm, on ior 1.0)."""
    path = khronos_gltf("SunglassesKhronos", tmp_path)
    row = json.loads(cli("plan", "--gltf", path, "--json").stdout)["gltf_materials"][0]
    assert cli("bake", "--gltf", path, "--out", tmp_path / "out").returncode == 0
    proc = cli(
        "sample",
        tmp_path / "out" / "SunglassesKhronos.exr",
        "--material",
        row["slice"],
        "--thickness",
        300.01,
        "--angle",
        40,
        "--json",
    )
    assert proc.returncode == 0, proc.stderr
    got = np.array(json.loads(proc.stdout)["points"][0]["rgb"])
    truth = reference_colour(FilmPoints.build(eta2=2.0, thickness_nm=300.01, angle_deg=40.0, eta3=1.0)).values[0]
    assert delta_e00(got, truth) <= 1.0


def _rows(tmp_path, materials, metal_mapping="fitted", **doc):
    scene = load_gltf_scene(write_gltf(tmp_path / "a.gltf", document(materials, **doc)), metal_mapping)
    return scene, material_rows(scene, plan_scene(scene))


def test_mapping_rules_film_thickness_base_and_defaults(tmp_path):
    scene, rows = _rows(
        tmp_path,
        [
            iridescent(ior=1.2345678901, d_max=321.5, base_ior=1.61),  # η2 as read; fixed thickness
            iridescent(d_min=700, d_max=250, thickness_texture=True),  # min > max: sorted range
            {"extensions": {"KHR_materials_iridescence": {}}, "pbrMetallicRoughness": {"metallicFactor": 0}},
            iridescent(iridescenceFactor=0.0),  # no film
            {"extensions": {"KHR_materials_iridescence": {}}},  # glTF's defaults: a white metal
        ],
        textures=[{}],
    )
    film = {m.name: m for m in scene.materials}
    assert rows[0]["film"] == 1.2345678901 and film[rows[0]["slice"]].film == 1.2345678901  # never snapped
    assert film[rows[0]["slice"]].thickness_nm == (321.5, 321.5) and film[rows[0]["slice"]].base == (1.61, 0.0)
    assert rows[1]["thickness_nm"] == [250.0, 700.0] and "sorted" in rows[1]["warnings"][0]
    default = film[rows[2]["slice"]]
    assert (default.film, default.thickness_nm, default.base) == (1.3, (400.0, 400.0), (1.5, 0.0))
    assert set(rows[2]["defaults"]) >= {"iridescenceIor", "iridescenceThicknessMaximum", "ior"}
    assert rows[3]["slice"] is None and rows[3]["why_not"] == "iridescenceFactor 0: no film"
    assert rows[4]["metalness"] == [1.0, 1.0] and rows[4]["bases"]["metal"]["f0"] == [1.0, 1.0, 1.0]
    assert "dielectric" not in rows[4]["bases"] and rows[4]["bases"]["metal"]["clamped"]


def test_unused_materials_are_listed_not_baked_and_draft_keys_warn(tmp_path):
    doc = document(
        [iridescent(), iridescent(ior=1.9, iridescenceIOR=1.5)],
        meshes=[{"primitives": [{"attributes": {}, "material": 1}]}],
    )
    scene = load_gltf_scene(write_gltf(tmp_path / "a.gltf", doc))
    rows = material_rows(scene, plan_scene(scene))
    assert rows[0]["slice"] is None and "not used" in rows[0]["why_not"]
    assert rows[1]["film"] == 1.9 and "draft spelling" in rows[1]["warnings"][0]
    assert all(m.name.startswith("m1-") for m in scene.materials)


def test_metal_mappings_and_the_white_metal_clamp(tmp_path):
    gold = [1.0, 0.78, 0.34]
    metal = iridescent(metallic=1.0, colour=gold)
    _, fitted = _rows(tmp_path, [metal])
    _, three = _rows(tmp_path, [metal], metal_mapping="threejs")
    f, t = fitted[0]["bases"]["metal"], three[0]["bases"]["metal"]
    assert f["clamped"] and "clamped" in fitted[0]["warnings"][0] and len(set(f["channels"])) == 3
    assert t["kappa3"] == [0.0, 0.0, 0.0] and t["eta3"][2] == pytest.approx((1 + 0.34**0.5) / (1 - 0.34**0.5))
    assert t["eta3"][0] == pytest.approx(10.0)  # F0 clamped where η would leave lutbake's domain
    named = tmp_path / "mapping.json"
    named.write_text(json.dumps({"materials": {"0": "Au"}}))
    scene, rows = _rows(tmp_path, [metal], metal_mapping=str(named))
    assert rows[0]["bases"]["metal"]["named"] == "Au" and [m.base for m in scene.materials] == ["Au"]
    extras = {**metal, "extras": {"lutbake": {"metal": "Cu"}}}
    assert [m.base for m in _rows(tmp_path, [extras])[0].materials] == ["Cu"]


def test_texture_driven_base_colour_gets_a_4d_job_over_its_mapping_curve(tmp_path):
    material = iridescent(metallic=1.0, colour=[0.9, 0.5, 0.2])
    material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    scene, rows = _rows(tmp_path, [material], textures=[{}])
    metal = rows[0]["bases"]["metal"]
    assert rows[0]["lut"] and metal["texture"] and metal["f0_max"] == [0.9, 0.5, 0.2]
    job = plan_scene(scene).jobs[0]
    (e_lo, e_hi), (k_lo, k_hi) = job.key["base"]
    table = metal["table"]
    assert table["f0"][0] == 0.0 and table["f0"][-1] == 0.9  # the brightest channel's reach
    assert (e_lo, e_hi, k_lo, k_hi) == (
        min(table["eta3"]),
        max(table["eta3"]),
        min(table["kappa3"]),
        max(table["kappa3"]),
    )


def test_random_hand_written_assets_bake_as_gltf_and_glb(tmp_path):
    """Random films (η2 1.0-2.5), thicknesses and dielectric bases: the .gltf bakes, its .glb twin plans the
    same jobs, and every slice holds its ground truth at fresh points."""
    rng = np.random.default_rng(5)
    materials = [
        iridescent(
            ior=float(rng.uniform(1.0, 2.5)), d_max=float(rng.uniform(50, 800)), base_ior=float(rng.uniform(1.0, 2.5))
        )
        for _ in range(4)
    ]
    doc = document(materials)
    gltf = write_gltf(tmp_path / "random.gltf", doc)
    glb = tmp_path / "random.glb"
    glb.write_bytes(glb_bytes({**doc, "buffers": [{"byteLength": 8}]}, b"\0" * 8))
    assert [j.hash for j in plan_scene(load_gltf_scene(glb)).jobs] == [
        j.hash for j in plan_scene(load_gltf_scene(gltf)).jobs
    ]
    proc = cli("bake", "--gltf", gltf, "--out", tmp_path / "out", "--json")
    assert proc.returncode == 0, proc.stderr
    atlas = Atlas.load(tmp_path / "out" / "random.exr")
    for name in atlas.materials:
        lo, hi = (atlas.slice_of(name)["axes"]["thickness_nm"][k] for k in ("min", "max"))
        pts = FilmPoints.build(**atlas.film_stack(name), cos_theta=rng.uniform(0, 1, 100), thickness_nm=lo)
        assert np.percentile(delta_e00(atlas.sample(name, pts), reference_colour(pts).values), 99) <= 1.0


def test_the_docs_credit_every_khronos_asset_the_fixture_carries():
    """CC-BY-4.0 asks for credit wherever something derived from an asset is shown: docs/gltf.md names every
    asset of the fixture (author, year, license, source), gltf-examples.md (make_gltf.py) every one it bakes."""
    docs = Path(__file__).resolve().parents[2] / "docs"
    for page, names in (("gltf.md", KHRONOS), ("gltf-examples.md", SHOWCASE)):
        text = (docs / page).read_text()
        missing = [name for name in names if f"- {name}: {credit_line(name)}\n" not in text]
        assert not missing, (page, missing)


def test_sphere_grids_plan_every_sphere(tmp_path):
    for name in SPHERE_GRIDS:
        scene = load_gltf_scene(khronos_gltf(name, tmp_path))
        rows = material_rows(scene, plan_scene(scene))
        assert len(rows) == 343 and all(r["slice"] for r in rows)


# --- metals ---------------------------------------------------------------------------------------


def test_conductor_reflectance_matches_tmm():
    tmm = pytest.importorskip("tmm")
    for eta, kappa, theta in ((0.3, 2.5, 0.7), (1.8, 1.06, 1.3), (1.5, 0.0, 1.0), (0.05, 2.3, 1.55)):
        expected = 0.5 * sum(tmm.coh_tmm(p, [1, eta + 1j * kappa], [np.inf, np.inf], theta, 500.0)["R"] for p in "sp")
        assert conductor_reflectance(eta, kappa, np.cos(theta)) == pytest.approx(expected, abs=1e-12)


def test_fitted_conductor_keeps_f0_and_stays_near_gltf_metal_curve():
    """Within 0.03 of glTF's Schlick curve for F0 ≥ 0.005; below, κ ≤ 2√F0 cannot follow the curve's
    white grazing edge (a black metal: max error → 1 at F0 = 0, docs/gltf.md)."""
    f0 = np.r_[0.005, np.linspace(0.01, F0_MAX["fitted"], 33)]
    eta, kappa, clamped = conductor(f0, "fitted")
    assert not clamped.any()
    assert np.allclose(conductor_reflectance(eta, kappa, 1.0), f0, atol=1e-12)  # F0 exact
    worst = max(reflectance_error(float(e), float(k), float(f))["max"] for e, k, f in zip(eta, kappa, f0))
    assert worst <= 0.03
    e3, k3, _ = conductor([0.5], "threejs")
    assert reflectance_error(float(e3[0]), float(k3[0]), 0.5)["max"] > 0.25  # three.js's index: far off
    assert gltf_metal_reflectance(0.5, 0.0) == 1.0
    e4, k4, _ = conductor([1e-4], "fitted")
    assert reflectance_error(float(e4[0]), float(k4[0]), 1e-4)["max"] > 0.1


def test_receipts_say_what_each_choice_costs(tmp_path):
    """`report OUT/ASSET.json`: per material the values read (defaults flagged), what was baked against the
    truth (within the target), three.js's own term (far off) and the other metal mapping's truth. The
    coloured metal is per channel: reading every channel from the red slice would miss the target."""
    doc = document(
        [
            iridescent(ior=1.4, d_min=200, d_max=500, thickness_texture=True),
            iridescent(ior=1.6, d_max=350, metallic=1.0, colour=[0.9, 0.6, 0.3]),
        ],
        textures=[{}],
    )
    gltf = write_gltf(tmp_path / "coat.gltf", doc)
    assert cli("bake", "--gltf", gltf, "--out", tmp_path / "out").returncode == 0
    proc = cli("report", tmp_path / "out" / "coat.json", "--points", 150, "--json", "--out", tmp_path / "rec")
    assert proc.returncode == 0, proc.stderr
    receipts = json.loads(proc.stdout)
    assert json.loads((tmp_path / "rec" / "receipts.json").read_text()) == receipts
    assert "<h2>material 1: (unnamed)</h2>" in (tmp_path / "rec" / "receipts.html").read_text()
    dielectric, metal = (r["parts"] for r in receipts["materials"])
    assert receipts["materials"][0]["read"]["ior"] == {"value": 1.5, "default": True}
    for part in (dielectric["dielectric"], metal["metal"]):
        assert part["de00"]["baked"]["de00_p99"] <= 1.0
        assert part["de00"]["threejs"]["de00_p99"] > 3 * part["de00"]["baked"]["de00_p99"]
    assert len(set(metal["metal"]["channels"])) == 3 and metal["metal"]["de00"]["other_mapping"]["mapping"] == "threejs"
    assert metal["metal"]["de00"]["other_mapping"]["de00_p99"] > 5  # the mapping matters more than any LUT error


def test_an_unchanged_asset_is_up_to_date_and_a_changed_material_rebakes_one_slice(tmp_path):
    doc = document([iridescent(ior=1.4, d_max=300, base_ior=1.5), iridescent(ior=1.8, d_max=500, base_ior=1.2)])
    gltf = write_gltf(tmp_path / "a.gltf", doc)
    first = bake_scene(load_gltf_scene(gltf), tmp_path / "out")
    assert len(first.computed) == 2 and bake_scene(load_gltf_scene(gltf), tmp_path / "out").up_to_date
    doc["materials"][1]["extensions"]["KHR_materials_iridescence"]["iridescenceThicknessMaximum"] = 520
    again = bake_scene(load_gltf_scene(write_gltf(gltf, doc)), tmp_path / "out")
    assert len(again.computed) == 1 and len(again.reused) == 1
