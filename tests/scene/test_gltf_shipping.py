"""What to ship from a glTF bake (issue 34 item 5): `bake --gltf` names the web set (what a three.js page with
engine/lutbake-gltf.js fetches) and the build artefacts; `--for web` writes the web set alone."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from gltf_assets import document, iridescent, khronos_gltf, write_gltf

ROOT = Path(__file__).resolve().parents[2]


def cli(*args):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def asset(tmp_path_factory):
    folder = tmp_path_factory.mktemp("ship")
    materials = [
        iridescent(ior=1.4, d_max=300),
        iridescent(ior=1.5, d_max=350, metallic=1.0, colour=[0.9, 0.7, 0.4], name="gold"),
        {**iridescent(ior=1.6), "extras": {"lutbake": {"route": "runtime"}}},
    ]
    return write_gltf(folder / "ship.gltf", document(materials))


def _imported_modules(entry: str) -> list[str]:
    """``entry`` and every project module it imports, directly or not (``from './x.js'``), in the order
    first imported: what a page that loads ``entry`` fetches besides the engine."""
    order, pending = [], [entry]
    while pending:
        module = pending.pop(0)
        if module not in order:
            order.append(module)
            text = (ROOT / module).read_text()
            pending += [f"engine/{name}" for name in re.findall(r"^import .* from '\./([\w.-]+\.js)';", text, re.M)]
    return order


def test_a_bake_names_the_web_set_and_the_build_artefacts(asset):
    """The web set is the manifest, the atlas and its GLSL include (what loadLutbakeBake fetches), beside the
    page's modules and the runtime table where a part uses it; the HLSL include and the cache are named as
    build artefacts with what they are for; `--json` carries the same under ``ship``."""
    out = asset.parent / "full"
    proc = cli("bake", "--gltf", asset, "--out", out, "--json")
    assert proc.returncode == 0, proc.stderr
    ship = json.loads(proc.stdout)["ship"]
    assert ship["web"] == ["ship.json", "ship.exr", "ship.glsl"] and ship["runtime_table_parts"] == 1
    assert ship["page_modules"] == _imported_modules("engine/lutbake-gltf.js")
    assert set(ship["build"]) == {"ship.hlsl", ".lutbake-cache/"} and "HLSL" in ship["build"]["ship.hlsl"]
    assert {p.name for p in out.iterdir()} == {*ship["web"], "ship.hlsl", ".lutbake-cache"}
    text = cli("bake", "--gltf", asset, "--out", out).stdout.splitlines()
    assert text[1].startswith("ship for the web (what engine/lutbake-gltf.js fetches): ship.json, ship.exr, ship.glsl")
    assert "runtime table (lutbake runtime-table --out DIR): 1 part(s)" in text[1]
    assert text[2].startswith("build artefacts (no page loads them): ship.hlsl: HLSL includes")


def test_for_web_writes_the_web_set_alone_and_stays_up_to_date(asset):
    """`--for web`: the manifest lists the web set alone and the folder holds nothing else (no HLSL, no cache);
    a second run writes nothing; the receipts read it; `--for web` without --gltf is refused in one line."""
    out = asset.parent / "web"
    proc = cli("bake", "--gltf", asset, "--out", out, "--for", "web")
    assert proc.returncode == 0, proc.stderr
    assert {p.name for p in out.iterdir()} == {"ship.json", "ship.exr", "ship.glsl"}
    manifest = json.loads((out / "ship.json").read_text())
    assert set(manifest["files"]) == {"ship.exr", "ship.glsl"}
    again = cli("bake", "--gltf", asset, "--out", out, "--for", "web")
    assert "up to date" in again.stdout and "build artefacts" not in again.stdout
    assert cli("report", out / "ship.json", "--points", 30, "--max-de", 1).returncode == 0
    toml = asset.parent / "films.toml"
    toml.write_text("[materials.soap]\nfilm = 1.33\nthickness_nm = [200, 600]\nbase = 1.0\n")
    refused = cli("bake", "--scene", toml, "--out", asset.parent / "toml", "--for", "web")
    assert refused.returncode == 2 and refused.stderr.strip().splitlines() == [
        "lutbake: error: --for web applies to --gltf bakes only"
    ]
    assert not (asset.parent / "toml").exists()


def test_for_web_into_a_full_bake_removes_the_build_artefacts_that_bake_wrote_and_nothing_else(asset):
    """`--for web` into a folder holding a full bake: the HLSL include and the cache entries that bake's manifest
    names go (one stdout line naming them, ``ship.removed`` in --json), the web set stays, files lutbake did not
    write stay (one beside the set, one in the cache folder, which then stays); a folder whose manifest is not
    lutbake's (edited: its seal broken) keeps every file."""
    out = asset.parent / "full-then-web"
    assert cli("bake", "--gltf", asset, "--out", out).returncode == 0
    cache_entries = sorted(f".lutbake-cache/{p.name}" for p in (out / ".lutbake-cache").iterdir())
    (out / "notes.txt").write_text("mine")
    (out / ".lutbake-cache" / "mine.txt").write_text("mine")
    proc = cli("bake", "--gltf", asset, "--out", out, "--for", "web", "--json")
    assert proc.returncode == 0, proc.stderr
    assert sorted(json.loads(proc.stdout)["ship"]["removed"]) == sorted(["ship.hlsl", *cache_entries])
    assert {p.name for p in out.iterdir()} == {"ship.json", "ship.exr", "ship.glsl", "notes.txt", ".lutbake-cache"}
    assert [p.name for p in (out / ".lutbake-cache").iterdir()] == ["mine.txt"]
    foreign = asset.parent / "foreign"
    assert cli("bake", "--gltf", asset, "--out", foreign).returncode == 0
    manifest = json.loads((foreign / "ship.json").read_text())
    (foreign / "ship.json").write_text(json.dumps({**manifest, "scene": "edited.gltf"}))
    text = cli("bake", "--gltf", asset, "--out", foreign, "--for", "web").stdout
    assert "removed" not in text and (foreign / "ship.hlsl").exists() and (foreign / ".lutbake-cache").is_dir()
    again = cli("bake", "--gltf", asset, "--out", out, "--for", "web").stdout
    assert "up to date" in again and "removed" not in again


def test_plan_estimates_the_bake_by_stage_measured_now_and_writes_nothing(asset):
    """`plan --json`'s ``estimate_seconds`` is its stages' sum (start-up, slices from jobs refined now, 4D LUTs,
    composed-colour checks: one here, the gold metal's three slices); the jobs it refined are the plan's; nothing
    is written (bench/bench_gltf_plan.py holds the estimate against the bake)."""
    before = sorted(p.name for p in asset.parent.iterdir())
    proc = cli("plan", "--gltf", asset, "--json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    stages = [doc[k] for k in ("startup_s", "slices_s", "luts_s", "checks_s")]
    assert doc["estimate_seconds"] == pytest.approx(sum(stages), rel=1e-12) and all(s >= 0 for s in stages)
    assert doc["checks_s"] > 0 and doc["luts_s"] == 0 and doc["slices_s"] > 0
    slice_ids = [j["id"] for j in doc["jobs"] if j["kind"] == "slice"]
    assert doc["sampled_slice_jobs"] and set(doc["sampled_slice_jobs"]) <= set(slice_ids)
    assert sorted(p.name for p in asset.parent.iterdir()) == before
    text = cli("plan", "--gltf", asset).stdout.splitlines()[-1]
    assert text.startswith("time ~") and "to bake here, measured just now" in text


def test_plan_refines_a_texture_driven_metal_now_and_says_each_parts_route(tmp_path):
    """CompareIridescence's texture-driven metal: `plan` refines its 4D job now (``sampled_lut_jobs``, counted
    in ``luts_s``: bench/bench_gltf_plan.py holds it within 2x of the bake) and says each part's route: a forced
    route as final, a baked part's as the bake's unless its check misses (only the bake can tell)."""
    gltf = khronos_gltf("CompareIridescence", tmp_path)
    doc = json.loads(cli("plan", "--gltf", gltf, "--json").stdout)
    luts = [j["id"] for j in doc["jobs"] if j["kind"] == "lut"]
    assert doc["sampled_lut_jobs"] == luts[:1] and len(luts) == 1 and doc["luts_s"] > 0
    (row,) = doc["gltf_materials"]
    assert row["routes"]["metal"] == {"route": "bake", "by": "auto", "unless": row["routes"]["metal"]["unless"]}
    assert "composed colour" in row["routes"]["metal"]["unless"] and "slice" in row["routes"]["dielectric"]["unless"]
    forced = json.loads(cli("plan", "--gltf", gltf, "--route", "1=runtime", "--json").stdout)
    assert forced["gltf_materials"][0]["routes"] == {p: {"route": "runtime", "by": "--route"} for p in row["routes"]}
    assert forced["luts_s"] == 0 and forced["sampled_lut_jobs"] == [] and not forced["jobs"]
    text = cli("plan", "--gltf", gltf, "--route", "1=runtime").stdout
    assert "metal → runtime (--route)" in text
