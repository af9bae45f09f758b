"""Routes of a glTF bake (issue 34 item 3): the bake's target check scores a part's composed colour as its
receipt does, so that the bake never calls met what the receipt fails; a part that misses goes to the runtime
table by itself (manifest, one printed line, receipt), unless the user forces the bake."""

import json
import subprocess
import sys

import pytest
from gltf_assets import document, iridescent, write_gltf

from lutbake.scene.gltf.receipt import gltf_receipts
from lutbake.scene.gltf.routes import planned_routes


def cli(*args):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *map(str, args)], capture_output=True, text=True)


def coloured_specular(**extra):
    """A dielectric base whose KHR_materials_specular colour makes each channel's F0 differ: three slices,
    each meeting p99 1.0 on its own, whose composed colour reaches p99 1.02-1.13 (issue 34)."""
    material = iridescent(ior=1.35, d_max=420, base_ior=1.6)
    material["extensions"]["KHR_materials_specular"] = {"specularFactor": 0.7, "specularColorFactor": [1.0, 0.4, 2.5]}
    return {**material, **extra}


def textured_metal(**extra):
    """A base-colour-textured metal: its 4D LUT, read per channel along the mapping's F0 table, misses the bound
    at the curve's dark end (docs/gltf.md), and a 4D LUT is not re-refined: the part goes to the runtime table."""
    material = iridescent(ior=1.5, d_max=400, metallic=1.0)
    material["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}
    return {**material, **extra}


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """The coloured specular forced to the bake (extras.lutbake.route; 1 nm thicker, so that its slices are its
    own), the same left to lutbake, and a texture-driven metal: (the folder, the bake's process)."""
    folder = tmp_path_factory.mktemp("routes")
    forced = coloured_specular(name="forced", extras={"lutbake": {"route": "bake"}})
    forced["extensions"]["KHR_materials_iridescence"]["iridescenceThicknessMaximum"] = 421
    materials = [forced, coloured_specular(name="free"), textured_metal(name="textured")]
    gltf = write_gltf(folder / "routes.gltf", document(materials, textures=[{}]))
    return folder, cli("bake", "--gltf", gltf, "--out", folder / "out")


def parts(folder):
    manifest = json.loads((folder / "out" / "routes.json").read_text())
    return manifest, [next(iter(r["parts"].values())) for r in manifest["source"]["materials"]]


def test_a_composed_miss_is_re_refined_once_and_what_still_misses_goes_to_the_runtime_table(baked):
    """The part left to lutbake: each channel's slice met the target, its composed colour did not (bound 1.174),
    so its slices were refined once more, each to its bound times 1/1.174, and it met: it stays baked, its
    check records the re-refinement. The texture-driven metal's composed colour misses and its 4D LUT is not
    re-refined: the runtime table serves it: route runtime, route_by auto and why in the manifest's source, no
    manifest entry for its LUT (engines then serve the part from the runtime table), its check rescored on the
    table, one stderr line naming the material and why (again when the set is up to date), the receipt's JSON
    and HTML say so. The forced part stays baked, unmet and not re-refined: exit 1 naming it (a bake never
    reports a target met that its receipt fails)."""
    folder, proc = baked
    manifest, (forced, free, textured) = parts(folder)
    again_check = free["target_check"]
    assert "route" not in free and again_check["served_by"] == "bake" and again_check["met"]
    assert again_check["rerefined"]["de00_p99_bound"] > 1.0 > again_check["de00_p99_bound"]
    assert again_check["rerefined"]["slice_factor"] == pytest.approx(1.0 / again_check["rerefined"]["de00_p99_bound"])
    assert set(free["channels"]) <= set(manifest["materials"])
    assert (
        textured["route"] == "runtime" and textured["route_by"] == "auto" and "composed colour" in textured["route_why"]
    )
    assert textured["target_check"]["served_by"] == "runtime" and textured["target_check"]["met"]
    assert not set(textured["channels"]) & set(manifest["materials"])  # engines read the runtime table for it
    assert all(manifest["materials"][n]["target_met"] for n in forced["channels"])  # each slice alone: met
    assert forced["route"] == "bake" and forced["target_check"]["served_by"] == "bake"
    assert not forced["target_check"]["met"] and forced["target_check"]["de00_p99_bound"] > 1.0
    assert "rerefined" not in forced["target_check"]
    lines = [line for line in proc.stderr.splitlines() if "runtime table" in line]
    assert lines == [
        "lutbake: routes.gltf: materials[2] 'textured': the metal part is served by the runtime table: "
        + textured["route_why"]
    ]
    assert proc.returncode == 1 and "materials[0] 'forced' dielectric part p99" in proc.stderr.splitlines()[-1]
    again = cli("bake", "--gltf", folder / "routes.gltf", "--out", folder / "out")
    assert "up to date" in again.stdout and lines[0] in again.stderr.splitlines() and again.returncode == 1
    report = cli("report", folder / "out" / "routes.json", "--points", 40, "--out", folder / "receipts")
    assert "(the runtime table (its composed colour" in report.stdout
    assert "the runtime table (its composed colour" in (folder / "receipts" / "receipts.html").read_text()


@pytest.mark.slow
def test_a_part_the_bake_calls_met_passes_its_receipt_at_every_seed(baked):
    """The seed sweep that would have caught the composed-colour miss: at 1,000 points, as `report` scores, a part
    the bake calls met (the re-refined one, the routed one on the runtime table) passes its receipt at every
    seed; the forced part, whose slices each call themselves met (what the bake used to report), fails its
    receipt at some seed, and the bake calls it unmet."""
    folder, _ = baked
    manifest, checked = parts(folder)
    verdicts = [part["target_check"]["met"] for part in checked]
    assert verdicts == [False, True, True]
    assert all(manifest["materials"][n]["target_met"] for n in checked[0]["channels"])
    served = []
    for seed in (1, 2, 3):
        receipts = gltf_receipts(folder / "out" / "routes.json", 1000, seed)
        served.append([next(iter(r["parts"].values()))["de00"]["baked"]["de00_p99"] for r in receipts["materials"]])
    assert all(max(p99[1:]) <= 1.0 for p99 in served) and any(p99[0] > 1.0 for p99 in served), served


def test_plan_says_which_parts_the_bake_may_still_reroute():
    """`plan`'s routes before the bake (hand-made records): a part the bake serves stays baked unless its check
    misses (a composed colour's or its slice's), except a named metal, which has no (η3, κ3) for the runtime
    table and so is final; forced routes and constants are final."""
    slice_part = {"material": "s", "base": [1.5, 0.0]}
    textured = {"texture": True, "channels": ["a", "a", "a"], "mapping": "fitted"}
    named = {"channels": ["n", "n", "n"], "mapping": "named", "named": "Au"}
    forced = {**slice_part, "route": "runtime", "route_by": "extras"}
    record = {
        "film": 1.3,
        "parts": {"d": slice_part, "t": textured, "n": named, "f": forced, "c": {"constant": [0] * 3}},
    }
    routes = planned_routes(record)
    assert "slice misses" in routes["d"]["unless"] and "composed colour" in routes["t"]["unless"]
    assert routes["n"] == {"route": "bake", "by": "auto"}
    assert routes["f"] == {"route": "runtime", "by": "extras"} and routes["c"] == {"route": "constant", "by": "stack"}
    assert planned_routes({"film": None, "parts": {"d": slice_part}}) == {}
