"""glTF as a scene source (issue 23): the Khronos showcase assets plan and bake, the mapping rules hold,
hand-written assets with random films bake, the metal mappings are what they claim."""

import copy
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

from lutbake.io.manifest import read_scene_manifest, sealed
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


_ON = {"iridescenceFactor": 1.0}  # the extension with every other key at its default


def _rows(tmp_path, materials, metal_mapping="fitted", **doc):
    scene = load_gltf_scene(write_gltf(tmp_path / "a.gltf", document(materials, **doc)), metal_mapping)
    return scene, material_rows(scene, plan_scene(scene))


def test_texture_driven_metals_share_one_metal_table_in_the_manifest(tmp_path):
    """Two texture-driven metals of one mapping: the manifest writes their F0 → (η3, κ3) table once, at its top
    level (``metal_tables``, named by the mapping), and each part names it; the reader gives the parts back with
    the table in place, equal to the plan's (also from a manifest written before metal_tables, its table inline);
    a part naming a table the manifest lacks, or a table that is not one, is refused by name."""
    materials = []
    for name in ("a", "b"):
        material = iridescent(metallic=1.0, name=name)
        material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
        materials.append(material)
    gltf = write_gltf(tmp_path / "t.gltf", document(materials, textures=[{}]))
    # Both parts forced to the runtime table: the tables are written all the same, and nothing 4D is baked.
    proc = cli("bake", "--gltf", gltf, "--out", tmp_path / "out", "--route", "a=runtime", "--route", "b=runtime")
    assert proc.returncode == 0, proc.stderr
    path = tmp_path / "out" / "t.json"
    raw = json.loads(path.read_text())
    (table,) = raw["metal_tables"].values()
    assert list(raw["metal_tables"]) == ["fitted"] and path.read_text().count('"f0"') == 1
    assert [r["parts"]["metal"]["table"] for r in raw["source"]["materials"]] == ["fitted", "fitted"]
    planned = _rows(tmp_path, materials, textures=[{}])[1][0]["bases"]["metal"]["table"]
    assert table == planned and table["f0"][-1] == F0_MAX["fitted"] and len(table["f0"]) == 65
    read = read_scene_manifest(path)
    assert [r["parts"]["metal"]["table"] for r in read["source"]["materials"]] == [planned, planned]
    # A manifest written before metal_tables, its table inline in each part, reads the same.
    inline = copy.deepcopy(raw)
    for record in inline["source"]["materials"]:
        record["parts"]["metal"]["table"] = table
    path.write_text(json.dumps(sealed({k: v for k, v in inline.items() if k not in ("manifest_hash", "metal_tables")})))
    read = read_scene_manifest(path)
    assert [r["parts"]["metal"]["table"] for r in read["source"]["materials"]] == [planned, planned]
    # A record the reader does not check (no film) may carry anything: it is not resolved, so nothing raises.
    skipped = copy.deepcopy(raw)
    skipped["source"]["materials"].append({"read": {}, "parts": {"metal": {"table": ["unhashable"]}}, "film": None})
    path.write_text(json.dumps(sealed({k: v for k, v in skipped.items() if k != "manifest_hash"})))
    assert read_scene_manifest(path)["source"]["materials"][2]["parts"]["metal"]["table"] == ["unhashable"]
    # A member no scene set has (the --for web clean-up names each member's role by its suffix).
    odd = {**raw, "files": {**raw["files"], "notes.txt": "0" * 64}}
    path.write_text(json.dumps(sealed({k: v for k, v in odd.items() if k != "manifest_hash"})))
    with pytest.raises(ValueError, match=r"files\.notes\.txt: not a member a scene set has"):
        read_scene_manifest(path)
    for bad in ("gold", ["unhashable"], {"f0": [0.0], "eta3": [1.0], "kappa3": [0.0]}):
        raw["source"]["materials"][1]["parts"]["metal"]["table"] = bad
        path.write_text(json.dumps(sealed({k: v for k, v in raw.items() if k != "manifest_hash"})))
        with pytest.raises(ValueError, match=r"parts\.metal\.table"):
            read_scene_manifest(path)


def test_mapping_rules_film_thickness_base_and_defaults(tmp_path):
    scene, rows = _rows(
        tmp_path,
        [
            iridescent(ior=1.2345678901, d_max=321.5, base_ior=1.61),  # η2 as read; fixed thickness
            iridescent(d_min=700, d_max=250, thickness_texture=True),  # min > max: sorted range
            {"extensions": {"KHR_materials_iridescence": _ON}, "pbrMetallicRoughness": {"metallicFactor": 0}},
            iridescent(iridescenceFactor=0.0),  # no film
            {"extensions": {"KHR_materials_iridescence": _ON}},  # glTF's defaults: a white metal
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
    assert rows[3]["slice"] is None and rows[3]["why_not"].startswith(
        "iridescenceFactor 0: the extension has no effect"
    )
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
        zero = [r for r in rows if all("constant" in p for p in r["bases"].values())]
        assert len(rows) == 343 and all(r["slice"] or r in zero for r in rows)


# --- metals ---------------------------------------------------------------------------------------


def test_conductor_reflectance_matches_tmm():
    import tmm  # a test dependency ([test] extra): missing, the test fails rather than skips

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


# --- the specifications' rules, each from its own text (KhronosGroup/glTF extensions/2.0/Khronos/*/README.md) ---


def test_iridescence_factor_defaults_to_zero_and_then_the_extension_has_no_effect(tmp_path):
    """KHR_materials_iridescence: "iridescenceFactor | number | The iridescence intensity factor. | No, default:
    0.0" and "If iridescenceFactor is zero (default), the iridescence extension has no effect on the material."
    A material that omits it (an iridescenceTexture alone included: "iridescence = iridescenceFactor *
    iridescenceTexture.r") is not baked, its receipt has no parts, and the manifest gives the three.js plugin
    no part to patch."""
    omitted = {"extensions": {"KHR_materials_iridescence": {"iridescenceIor": 1.8}}}
    texture_only = {"extensions": {"KHR_materials_iridescence": {"iridescenceTexture": {"index": 0}}}}
    doc = document([omitted, texture_only, iridescent(ior=1.8)], textures=[{}])
    scene, rows = _rows(tmp_path, doc.pop("materials"), **{k: v for k, v in doc.items() if k == "textures"})
    assert [r["read"]["iridescenceFactor"] for r in rows[:2]] == [{"value": 0.0, "default": True}] * 2
    assert all(r["slice"] is None and r["lut"] is None and "(its default: omitted)" in r["why_not"] for r in rows[:2])
    assert [m.name for m in scene.materials] == ["m2-dielectric"]
    gltf = write_gltf(tmp_path / "f.gltf", document([omitted, iridescent(ior=1.8)]))
    assert cli("bake", "--gltf", gltf, "--out", tmp_path / "out").returncode == 0
    manifest = json.loads((tmp_path / "out" / "f.json").read_text())
    assert [r["parts"] for r in manifest["source"]["materials"]][0] == {}  # the plugin patches parts only
    receipt = json.loads(cli("report", tmp_path / "out" / "f.json", "--points", 20, "--json").stdout)
    assert receipt["materials"][0]["parts"] == {} and receipt["materials"][1]["parts"]


def test_film_defaults_and_the_thickness_rules(tmp_path):
    """KHR_materials_iridescence: "iridescenceIor ... No, default: 1.3", "iridescenceThicknessMinimum ...
    No, default: 100.0", "iridescenceThicknessMaximum ... No, default: 400.0"; "If the thickness texture is not
    present, it is implicitly sampled as 1.0 so the thin-film thickness is uniformly set to the
    iridescenceThicknessMaximum value"; with it, "thickness = mix(iridescenceThicknessMinimum,
    iridescenceThicknessMaximum, iridescenceThicknessTexture.g)", and "The iridescenceThicknessMinimum value
    MAY be greater than iridescenceThicknessMaximum value" (the same range, read from the other end)."""
    texture = {"iridescenceThicknessTexture": {"index": 0}}
    plain = {"metallicFactor": 0}
    materials = [
        {"extensions": {"KHR_materials_iridescence": _ON}, "pbrMetallicRoughness": plain},
        {"extensions": {"KHR_materials_iridescence": {**_ON, **texture}}, "pbrMetallicRoughness": plain},
        {
            "extensions": {"KHR_materials_iridescence": {**_ON, **texture, "iridescenceThicknessMinimum": 900}},
            "pbrMetallicRoughness": plain,
        },
    ]
    scene, rows = _rows(tmp_path, materials, textures=[{}])
    assert [r["film"] for r in rows] == [1.3, 1.3, 1.3]
    assert [r["thickness_nm"] for r in rows] == [[400.0, 400.0], [100.0, 400.0], [400.0, 900.0]]
    assert {"iridescenceIor", "iridescenceThicknessMinimum", "iridescenceThicknessMaximum"} <= set(rows[1]["defaults"])


def test_ior_default_valid_values_and_the_specular_glossiness_mode(tmp_path):
    """KHR_materials_ior: "ior | number | The index of refraction. | No, default: 1.5"; "Valid values for ior are
    numbers greater than or equal to one. As a special case, a value of zero is allowed"; at zero "The effective
    IOR becomes positive infinity and the Fresnel term MUST evaluate to 1.0". KHR_materials_iridescence: "The
    base_ior can be changed using the KHR_materials_ior extension" (of the dielectric; the metal's base is its
    base colour). An infinite index has no base in lutbake's domain: F0 1 is clamped at η3 10 and said so; a
    value between 0 and 1 is baked as read, with a warning."""
    scene, rows = _rows(
        tmp_path,
        [iridescent(), iridescent(base_ior=0.0), iridescent(base_ior=0.5), iridescent(base_ior=1.7, metallic=1.0)],
    )
    assert rows[0]["bases"]["dielectric"]["base"] == [1.5, 0.0] and "ior" in rows[0]["defaults"]
    zero = rows[1]["bases"]["dielectric"]
    assert zero["base"] == [pytest.approx(10.0), 0.0] and zero["f0"] == [1.0, 1.0, 1.0]
    assert "clamped" in rows[1]["warnings"][0]
    assert (
        rows[2]["bases"]["dielectric"]["base"] == [0.5, 0.0]
        and "valid values are 0 or at least 1" in rows[2]["warnings"][0]
    )
    assert "dielectric" not in rows[3]["bases"] and rows[3]["bases"]["metal"]["f0"] == [1.0, 1.0, 1.0]


def test_specular_sets_the_dielectric_base_f0_per_channel_and_the_receipt_holds(tmp_path):
    """KHR_materials_iridescence with KHR_materials_specular: "base_f0 = ((1-base_ior)/(1+base_ior))^2 *
    base_f0_color", "base_f0 = min(base_f0, float3(1.0))", then "iridescent_fresnel(outside_ior,
    iridescence_ior, specular_weight * base_f0, iridescence_thickness)"; KHR_materials_specular:
    "specularFactor ... No, default: 1.0", "specularColorFactor ... No, default: [1.0, 1.0, 1.0]", "The metal
    BRDF is not affected by the parameter". Each channel's base is the real index whose F0 under air is that
    (the extension's Fresnel0ToIor); at the defaults it is the ior itself. Its textures vary F0 per texel:
    baked at the factors, named in one warning per asset. In the receipt a grey specular's slice holds its
    target; a coloured one, a slice per channel, is far closer than three.js's own term (its composed colour's
    p99 reaches 1.02-1.13 at 1,000 points where each slice holds 1.0: docs/gltf.md, issue 34 item 3)."""
    coloured = iridescent(ior=1.35, d_max=420, base_ior=1.6)
    coloured["extensions"]["KHR_materials_specular"] = {"specularFactor": 0.7, "specularColorFactor": [1.0, 0.4, 2.5]}
    default = iridescent(ior=1.35, base_ior=1.6)
    default["extensions"]["KHR_materials_specular"] = {}
    textured = iridescent(ior=1.9, metallic=0.5)
    textured["extensions"]["KHR_materials_specular"] = {"specularFactor": 0.5, "specularTexture": {"index": 0}}
    doc = document([coloured, default, textured], textures=[{}])
    scene = load_gltf_scene(write_gltf(tmp_path / "spec.gltf", doc))
    parts = [r["parts"] for r in scene.source["materials"]]
    f0_ior = (0.6 / 2.6) ** 2
    want = [0.7 * min(f0_ior * c, 1.0) for c in (1.0, 0.4, 2.5)]
    eta = np.array(parts[0]["dielectric"]["eta3"])
    assert (
        np.allclose(((eta - 1) / (eta + 1)) ** 2, want, rtol=1e-12)
        and len(set(parts[0]["dielectric"]["channels"])) == 3
    )
    assert parts[1]["dielectric"]["base"] == [1.6, 0.0]  # the defaults: the ior exactly
    root = (0.5 * 0.04) ** 0.5  # F0 = 0.5 × ((1.5 - 1)/(1.5 + 1))^2
    assert parts[2]["dielectric"]["base"] == [pytest.approx((1 + root) / (1 - root)), 0.0]
    assert parts[2]["metal"]["f0"] == [1.0, 1.0, 1.0]  # the metal part: its base colour only
    notes = [w for w in scene.source["asset_warnings"] if "specular textures" in w]
    assert len(notes) == 1 and "materials[2]" in notes[0]
    assert cli("bake", "--gltf", tmp_path / "spec.gltf", "--out", tmp_path / "out").returncode == 0
    proc = cli("report", tmp_path / "out" / "spec.json", "--points", 200, "--json")
    assert proc.returncode == 0, proc.stderr
    coloured_receipt, _, grey = (r["parts"]["dielectric"]["de00"] for r in json.loads(proc.stdout)["materials"])
    assert 3 * coloured_receipt["baked"]["de00_p99"] < coloured_receipt["threejs"]["de00_p99"]
    assert grey["baked"]["de00_p99"] <= 1.0 < grey["threejs"]["de00_p99"]


def test_variants_bake_every_material_a_primitive_can_show(tmp_path):
    """KHR_materials_variants: "When the active variant is referenced in a mapping, a compliant viewer will
    apply its material to the primitive" and "When no mapping contains the active variant, or there is no
    active variant, a compliant viewer will fall back on vanilla glTF behaviour for the primitive": the
    primitive's own material and each mapped one are baked; a material no primitive or mapping names is not."""
    mappings = {"mappings": [{"material": 1, "variants": [0]}, {"material": 2, "variants": [1]}]}
    primitive = {"attributes": {}, "material": 0, "extensions": {"KHR_materials_variants": mappings}}
    doc = document(
        [iridescent(ior=1.4), iridescent(ior=1.45), iridescent(ior=1.6), iridescent(ior=1.7)],
        meshes=[{"primitives": [primitive]}],
        extensions={"KHR_materials_variants": {"variants": [{"name": "a"}, {"name": "b"}]}},
    )
    _, rows = _rows(tmp_path, doc.pop("materials"), meshes=doc["meshes"], extensions=doc["extensions"])
    assert [r["used_by"] for r in rows] == [["primitive"], ["a"], ["b"], []]
    assert [bool(r["slice"]) for r in rows] == [True, True, True, False] and "not used" in rows[3]["why_not"]


def test_other_extensions_on_a_film_are_named_in_one_warning_per_asset(tmp_path):
    """Extensions that put a layer over the film or change what its base does (KHR_materials_iridescence:
    "When adding a clearcoat ontop, an additional interface between the clearcoat and thin-film layer would be
    created. Due to simplicity and artistical friendlyness, this interface is ignored") and its Exclusions
    ("This extension must not be used on a material that also uses KHR_materials_unlit"): one warning for the
    asset naming each extension and the materials with a film that use it; none for a material without one."""
    coat, sheen, unlit, off = iridescent(), iridescent(ior=1.45), iridescent(ior=1.6), iridescent(iridescenceFactor=0)
    coat["extensions"]["KHR_materials_clearcoat"] = {"clearcoatFactor": 1}
    sheen["extensions"].update(KHR_materials_sheen={}, KHR_materials_clearcoat={})
    unlit["extensions"]["KHR_materials_unlit"] = {}
    off["extensions"]["KHR_materials_sheen"] = {}  # no film: nothing baked, nothing to say
    scene = load_gltf_scene(write_gltf(tmp_path / "x.gltf", document([coat, sheen, unlit, off])))
    lines = [w for w in scene.source["asset_warnings"] if "change what the film" in w]
    assert len(lines) == 1
    assert "KHR_materials_clearcoat on materials[0] '', materials[1] ''" in lines[0]
    assert "KHR_materials_sheen on materials[1] ''" in lines[0] and "materials[3]" not in lines[0]
    assert "KHR_materials_unlit on materials[2] '': KHR_materials_iridescence must not be used with it" in lines[0]


def test_stacks_with_nothing_to_bake_are_served_without_a_bake_and_said_so(tmp_path):
    """A film of the ambient's index on a base of it (IridescenceMetallicSpheres' black metal under
    iridescenceIor 1, the fitted mapping's F0 0: vacuum over vacuum) reflects nothing: its part is the constant
    0, served without a bake (the plugin writes vec3(0.0)), one line per asset says so, and the bake exits 0
    (it exited 1 on those seven spheres, "p99 ΔE00 0.000 (bound 65.121)"). A film of the ambient's index on any
    other base is baked as usual."""
    scene = load_gltf_scene(khronos_gltf("IridescenceMetallicSpheres", tmp_path))
    zero = [r for r in scene.source["materials"] if r.get("zero_term")]
    assert len(zero) == 7 and all(r["read"]["iridescenceIor"]["value"] == 1 for r in zero)
    assert all(r["read"]["baseColorFactor"]["value"][:3] == [0, 0, 0] for r in zero)
    assert len(scene.materials) == 343 - 7
    doc = document([iridescent(ior=1.0, metallic=1.0, colour=[0, 0, 0]), iridescent(ior=1.0, base_ior=1.5)])
    proc = cli("bake", "--gltf", write_gltf(tmp_path / "v.gltf", doc), "--out", tmp_path / "out")
    assert proc.returncode == 0, proc.stderr
    assert [x for x in proc.stderr.splitlines() if "1 iridescent material with a part that has nothing" in x]
    small = load_gltf_scene(tmp_path / "v.gltf")
    assert "vacuum over vacuum" in material_rows(small, plan_scene(small))[0]["why_not"]  # what `plan` prints
    manifest = json.loads((tmp_path / "out" / "v.json").read_text())
    parts = [r["parts"] for r in manifest["source"]["materials"]]
    assert (
        parts[0]["metal"]["constant"] == [0.0, 0.0, 0.0] and parts[1]["dielectric"]["material"] in manifest["materials"]
    )
    receipt = json.loads(cli("report", tmp_path / "out" / "v.json", "--points", 40, "--json").stdout)
    assert receipt["materials"][0]["parts"]["metal"]["de00"]["baked"]["de00_max"] == 0.0


# --- receipts as a CI gate ------------------------------------------------------------------------------


def _baked(tmp_path, materials, *flags):
    """`bake --gltf` of ``materials`` into tmp_path/out: the manifest's path."""
    tmp_path.mkdir(parents=True, exist_ok=True)
    gltf = write_gltf(tmp_path / "g.gltf", document(materials))
    proc = cli("bake", "--gltf", gltf, "--out", tmp_path / "out", *flags)
    assert proc.returncode == 0, proc.stderr
    return tmp_path / "out" / "g.json"


def test_report_gates_ci_honours_points_and_shows_progress(tmp_path):
    """`report ASSET.json --max-de X` exits 1 when a part's baked p99 is above X (0 at or below), in text and
    JSON; --points is honoured up to its bound and refused past it in one line (exit 2, nothing written);
    --progress shows a line per material."""
    manifest = _baked(tmp_path, [iridescent(ior=1.4, d_max=300), iridescent(ior=1.7, metallic=1.0, colour=[0.8] * 3)])
    fail = cli("report", manifest, "--points", 40, "--max-de", 0.01)
    assert fail.returncode == 1 and "gate: worst served p99 ΔE00" in fail.stdout and "FAIL" in fail.stdout
    doc = json.loads(cli("report", manifest, "--points", 40, "--max-de", 0.01, "--json").stdout)
    assert doc["gate"]["passed"] is False and doc["points_per_part"] == 40
    worst = max(p["de00"]["baked"]["de00_p99"] for r in doc["materials"] for p in r["parts"].values())
    assert doc["gate"]["de00_p99"] == worst
    passing = cli("report", manifest, "--points", 40, "--max-de", 5, "--progress")
    assert passing.returncode == 0 and "pass" in passing.stdout
    assert "2/2" in passing.stderr and "material 1" in passing.stderr
    refused = cli("report", manifest, "--points", 10_001, "--out", tmp_path / "rec")
    assert refused.returncode == 2 and not (tmp_path / "rec").exists()
    assert refused.stderr.strip().splitlines() == [
        "lutbake: error: --points 10001 is not allowed for a glTF bake's receipts: at most 10000 per part"
    ]


def test_every_metal_mapping_has_a_receipt_and_it_separates_threejs_from_gltfs_model(tmp_path):
    """Receipts for the threejs and named mappings (fitted: test_receipts_say_what_each_choice_costs). A named
    metal's three.js term is fed the glTF material's base colour, which is what three.js shows (the receipt
    crashed on it: "--base NAME 'Au' differs from the khr-iridescence-threejs's base"). Each part splits
    three.js's error into three.js vs KHR_materials_iridescence's model (the same F0: small) and that model vs
    the physics (on a near-black metal, the fitted mapping's departure from Schlick's curve: large)."""
    named = tmp_path / "named.json"
    named.write_text(json.dumps({"materials": {"0": "Au"}}))
    for mapping in ("threejs", str(named)):
        folder = tmp_path / Path(mapping).stem
        manifest = _baked(
            folder, [iridescent(ior=1.5, d_max=350, metallic=1.0, colour=[0.9, 0.7, 0.4])], "--metal-mapping", mapping
        )
        proc = cli("report", manifest, "--points", 60, "--json")
        assert proc.returncode == 0, proc.stderr
        costs = json.loads(proc.stdout)["materials"][0]["parts"]["metal"]["de00"]
        assert costs["baked"]["de00_p99"] <= 1.0 < costs["threejs"]["de00_p99"], (mapping, costs)
    dark = _baked(tmp_path / "dark", [iridescent(ior=1.6, d_max=500, metallic=1.0, colour=[0.01] * 3)])
    costs = json.loads(cli("report", dark, "--points", 200, "--json").stdout)["materials"][0]["parts"]["metal"]["de00"]
    assert 5 * costs["threejs_vs_gltf_model"]["de00_p99"] < costs["gltf_model_vs_physics"]["de00_p99"], costs


# --- routes ---------------------------------------------------------------------------------------------


def test_a_material_can_be_sent_to_the_runtime_table_by_flag_or_extras(tmp_path):
    """`--route NAME=runtime` or the material's extras.lutbake.route "runtime": its parts are not baked, the
    manifest says route runtime (the three.js plugin then serves them from the table), `plan` says so, and
    the receipt scores the runtime table at its points; --route MATERIAL=bake overrides the extras. A value
    that is neither, or names no material, is refused in one line (exit 2)."""
    extras = {**iridescent(ior=1.4, d_max=300), "extras": {"lutbake": {"route": "runtime"}}}
    metal = iridescent(ior=1.8, d_max=500, metallic=1.0, colour=[0.9, 0.6, 0.3], name="gold")
    flagged_back = {**iridescent(ior=1.6), "extras": {"lutbake": {"route": "runtime"}}}
    gltf = write_gltf(tmp_path / "r.gltf", document([extras, metal, flagged_back]))
    plan = json.loads(cli("plan", "--gltf", gltf, "--route", "gold=runtime", "--route", "2=bake", "--json").stdout)
    rows = plan["gltf_materials"]
    assert [r["runtime_parts"] for r in rows] == [["dielectric"], ["metal"], []]
    assert rows[0]["slice"] is None and "runtime table" in rows[0]["why_not"] and rows[2]["slice"]
    proc = cli("bake", "--gltf", gltf, "--out", tmp_path / "out", "--route", "gold=runtime", "--route", "2=bake")
    assert proc.returncode == 0, proc.stderr
    manifest = json.loads((tmp_path / "out" / "r.json").read_text())
    parts = [r["parts"] for r in manifest["source"]["materials"]]
    assert parts[0]["dielectric"]["route_by"] == "extras.lutbake.route" and parts[1]["metal"]["route_by"] == "--route"
    baked = set(manifest["materials"])
    assert not baked & set(parts[1]["metal"]["channels"]) and parts[2]["dielectric"]["material"] in baked
    receipt = json.loads(cli("report", tmp_path / "out" / "r.json", "--points", 60, "--json").stdout)
    for row in receipt["materials"][:2]:
        (part,) = row["parts"].values()
        assert part["route"] == "runtime" and part["de00"]["baked"]["de00_p99"] <= 0.3  # the table's contract p99
    bad = cli("plan", "--gltf", gltf, "--route", "gold=gpu")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "--route 'gold=gpu'" in bad.stderr
