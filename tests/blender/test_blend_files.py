"""Blender files that travel (docs/blender.md, "Files that travel"): a .blend that `lutbake blender` wrote
names every table relative to itself (``//NAME``), the OSL scripts' too, so the file and its tables render
the same colours after they move together; Report Missing Files sees every table, Pack Resources packs
them; the OSL materials show magenta, with a one-line warning, where OSL does not run or their table is
missing. The renders open the .blend itself, as a user does (probe.py's job key ``open``)."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from blender_harness import blend_file_state, blender_python

from lutbake.blender.library import (
    RENDER_TOLERANCE,
    lutbake_probes,
    osl_job_probes,
    probe_points,
    read_scene,
    render_probes,
)
from lutbake.blender.nodes import OSL_FALLBACK_RGB, osl_warning

SCENE = """
scene = { precision = "float", space = "rec709", max_de = 3.0 }
materials.lacquer = { film = 1.45, thickness_nm = [250, 650], base = 1.52 }
"""
OSL_KINDS = {"exact": ("exact-table", "--exact"), "runtime": ("runtime-table", "--runtime-table")}
N_PROBES = 6  # per material
MAGENTA_TOLERANCE = 2e-3  # EEVEE keeps closure colours in a 10-bit G-buffer (docs/blender.md)


def _lutbake(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "lutbake", *args], capture_output=True, text=True)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """A folder holding a scene bake, an exact and a runtime table, and two libraries of all three, written by
    the commands a user runs: ``linked.blend`` (--link) and ``packed.blend`` (the default)."""
    blender = blender_python()
    folder = tmp_path_factory.mktemp("travel") / "made"
    folder.mkdir()
    (folder / "scene.toml").write_text(SCENE)
    assert _lutbake("bake", "--scene", str(folder / "scene.toml"), "--out", str(folder)).returncode == 0
    tables = [str(folder / "scene.json")]
    for kind, (command, flag) in OSL_KINDS.items():
        assert _lutbake(command, "--out", str(folder / f"{kind}.exr")).returncode == 0
        tables += [flag, str(folder / f"{kind}.exr")]
    reports = {}
    for name, link in (("linked", ["--link"]), ("packed", [])):
        done = _lutbake("blender", *tables, "--out", str(folder / f"{name}.blend"), "--blender", blender, *link)
        assert done.returncode == 0, done.stderr
        reports[name] = done
    scene = read_scene(folder / "scene.json")
    probes = [probe_points(scene, read, N_PROBES) for read in scene.reads]
    return {"blender": blender, "folder": folder, "reports": reports, "scene": scene, "probes": probes}


def _render(made: dict, blend: Path, engine: str = "CYCLES", osl: bool = True) -> dict:
    """Render the scene's material and the two OSL materials of ``blend``, opened as a user opens it, at
    N_PROBES each: their RGB by material."""
    materials, job_probes = lutbake_probes(made["scene"], blend, made["probes"])
    for kind in OSL_KINDS:
        materials.append({"kind": "lutbake", "library": str(blend), "material": f"lutbake {kind}"})
        job_probes += osl_job_probes(N_PROBES, material=len(materials) - 1)
    job = {"engine": engine, "osl": osl, "open": str(blend), "materials": materials, "probes": job_probes}
    rgb = np.asarray(render_probes(job, made["blender"])["rgb"]).reshape(len(materials), N_PROBES, 3)
    return dict(zip([p.material for p in made["probes"]] + list(OSL_KINDS), rgb, strict=True))


def _sampled(made: dict) -> np.ndarray:
    """What `lutbake sample` returns at the scene material's probes, held at 0 as Blender's closures are."""
    return np.maximum(made["probes"][0].expected, 0.0)


@pytest.fixture(scope="module")
def unmoved(made):
    """Renders of both libraries where they were written; the scene's material is what lutbake samples."""
    renders = {name: _render(made, made["folder"] / f"{name}.blend") for name in ("linked", "packed")}
    for render in renders.values():
        assert np.abs(render["lacquer"] - _sampled(made)).max() <= 1e-5
        for kind in OSL_KINDS:  # the OSL materials found their tables
            assert np.abs(render[kind] - OSL_FALLBACK_RGB).max(axis=1).min() > 0.1
    return renders


def _same(a: dict, b: dict, materials=("lacquer", *OSL_KINDS)) -> float:
    return max(float(np.abs(a[m] - b[m]).max()) for m in materials)


def _is_magenta(rgb: np.ndarray) -> bool:
    return float(np.abs(rgb - OSL_FALLBACK_RGB).max()) <= MAGENTA_TOLERANCE


def test_a_library_and_its_tables_render_the_same_after_they_move(made, unmoved, tmp_path):
    """The folder moved elsewhere and the original renamed away: the linked library renders what it
    rendered (OSL materials included), Report Missing Files reports nothing; without its tables it reports
    each of them and the OSL materials render magenta, not other colours."""
    moved = tmp_path / "elsewhere" / "moved"
    shutil.copytree(made["folder"], moved)
    made["folder"].rename(made["folder"].with_name("made-away"))
    try:
        assert _same(_render(made, moved / "linked.blend"), unmoved["linked"]) <= RENDER_TOLERANCE
        state = blend_file_state(made["blender"], moved / "linked.blend")
        assert state["none_missing"] and not state["missing"], state
        assert sorted(i["path"] for i in state["images"].values()) == ["//exact.exr", "//runtime.exr", "//scene.exr"]
        for name in ("scene.exr", "exact.exr", "runtime.exr"):
            (moved / name).rename(moved / f"{name}.away")
        state = blend_file_state(made["blender"], moved / "linked.blend")
        assert len(state["missing"]) == 3 and not state["none_missing"], state
        render = _render(made, moved / "linked.blend")
        assert all(_is_magenta(render[kind]) for kind in OSL_KINDS), render
    finally:
        made["folder"].with_name("made-away").rename(made["folder"])


def test_pack_resources_packs_the_tables_and_unpacking_restores_the_osl_reads(made, unmoved, tmp_path):
    """A packed library holds every table, the OSL scripts' too. Moved alone, its node groups render what
    they rendered; its OSL materials (OSL reads files, not packed images) render magenta until the tables
    are unpacked to their original location (//NAME beside the .blend), then what they rendered."""
    state = blend_file_state(made["blender"], made["folder"] / "packed.blend")
    assert {name: image["packed"] for name, image in state["images"].items()} == dict.fromkeys(
        ("exact.exr", "runtime.exr", "scene.exr"), True
    )
    alone = tmp_path / "alone"
    alone.mkdir()
    shutil.copy(made["folder"] / "packed.blend", alone)
    render = _render(made, alone / "packed.blend")
    assert _same(render, unmoved["packed"], ("lacquer",)) <= RENDER_TOLERANCE
    assert all(_is_magenta(render[kind]) for kind in OSL_KINDS), render
    blend_file_state(made["blender"], alone / "packed.blend", unpack=True)
    assert sorted(p.name for p in alone.glob("*.exr")) == ["exact.exr", "runtime.exr", "scene.exr"]
    assert _same(_render(made, alone / "packed.blend"), unmoved["packed"]) <= RENDER_TOLERANCE


@pytest.mark.parametrize("engine", ["CYCLES", "BLENDER_EEVEE"])
def test_osl_materials_show_magenta_and_warn_where_osl_does_not_run(made, unmoved, engine):
    """Cycles with OSL off, and EEVEE: the OSL materials render the documented magenta mirror (not a grey
    one), the node groups what they render with OSL; the script's text block and `lutbake blender` say so
    in one line each."""
    render = _render(made, made["folder"] / "linked.blend", engine, osl=False)
    assert all(_is_magenta(render[kind]) for kind in OSL_KINDS), render
    assert np.abs(render["lacquer"] - _sampled(made)).max() <= (1e-5 if engine == "CYCLES" else 2e-3)
    warnings = [osl_warning(f"lutbake {kind}") for kind in OSL_KINDS]
    texts = blend_file_state(made["blender"], made["folder"] / "linked.blend")["texts"]
    assert sorted(texts.values()) == sorted(f"// lutbake: {w}" for w in warnings)
    for done in made["reports"].values():
        assert done.stderr.splitlines() == [f"lutbake: warning: {w}" for w in warnings]


def test_the_json_report_holds_the_warnings(made, tmp_path):
    """`lutbake blender --json`: the warnings are fields of the document too."""
    out = tmp_path / "runtime.blend"
    done = _lutbake(
        "blender",
        "--runtime-table",
        str(made["folder"] / "runtime.exr"),
        "--out",
        str(out),
        "--blender",
        made["blender"],
        "--json",
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["warnings"] == [osl_warning("lutbake runtime")]
