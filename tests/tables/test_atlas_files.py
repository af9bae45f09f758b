"""Scene atlases are first-class LUT files: inspect, sample (by material) and report read them."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import DEFAULT_LUTS, default_luts

from lutbake.errors import ParameterError
from lutbake.lut.sample import Atlas, load_table
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs"))
from make_scene_examples import bake_example  # noqa: E402

ATLAS = ROOT / "docs" / "scenes" / "tempered-steel" / "tempered-steel.exr"
LUT = DEFAULT_LUTS / "lutbake-eta2-1.50.exr"  # a 4D LUT of the default set


@pytest.fixture(scope="module", autouse=True)
def luts():
    bake_example("tempered-steel")  # docs/scenes is baked here, not kept in the repository (docs/design-notes.md)
    return default_luts()


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "lutbake.cli", *map(str, args)], capture_output=True, text=True, cwd=ROOT
    )


def stack(atlas: Atlas, material: str, cos_theta, thickness_nm) -> FilmPoints:
    """The material's film stacks (its ambient, film and base, from the atlas) at (cos θ1, d)."""
    return FilmPoints.build(cos_theta=cos_theta, thickness_nm=thickness_nm, **atlas.film_stack(material))


def truth(atlas: Atlas, pts: FilmPoints):
    return reference_colour(pts, atlas.meta["observer"], atlas.meta["space"]).values


@pytest.mark.parametrize("material", ["steel_constant", "steel_werner"])
def test_atlas_nodes_hold_their_own_materials_ground_truth(material):
    """At the slice's nodes the sampler returns stored texels: the ground truth to half precision,
    so each material's rect holds that material (not a neighbour's rows). Every third node column and
    row and the last ones (both ends of each axis): an offset or flipped rect moves every one of them;
    the dispersive base's ground truth is the cost (all 32×36 nodes took 17 s)."""
    atlas = load_table(ATLAS)
    _, _, w, h = atlas.slice_of(material)["rect"]
    th = atlas.slice_of(material)["axes"]["thickness_nm"]
    cols, rows = (np.unique(np.r_[np.arange(0, n, 3), n - 1]) for n in (w, h))
    cos_t, d = np.meshgrid((np.linspace(0, 1, w) ** 2)[cols], np.linspace(th["min"], th["max"], h)[rows])
    pts = stack(atlas, material, cos_t.ravel(), d.ravel())
    expected = truth(atlas, pts)
    assert np.abs(atlas.sample(material, pts) - expected).max() <= 2e-3  # half: 2^-11 relative, values ≤ ~0.7
    others = [m for m in atlas.materials if m != material]
    assert all(
        np.abs(atlas.sample(m, stack(atlas, m, cos_t.ravel(), d.ravel())) - expected).max() > 1e-2 for m in others
    )


def test_atlas_refuses_a_stack_of_another_material():
    """A slice holds one film and base: another material's stack is refused, naming both bases."""
    atlas = load_table(ATLAS)
    werner = stack(atlas, "steel_werner", 0.5, 40.0)
    with pytest.raises(ParameterError, match=r"^base .* differs from the material 'steel_constant''s base = None$"):
        atlas.sample("steel_constant", werner)


def test_atlas_sample_between_nodes_is_bilinear():
    atlas = load_table(ATLAS)
    x0, y0, w, h = atlas.slice_of("steel_werner")["rect"]
    th = atlas.slice_of("steel_werner")["axes"]["thickness_nm"]
    step = (th["max"] - th["min"]) / (h - 1)
    cos_mid = ((3 + 0.5) / (w - 1)) ** 2  # halfway between nodes 3 and 4 in √cos θ
    got = atlas.sample("steel_werner", stack(atlas, "steel_werner", cos_mid, th["min"] + 5.5 * step))
    corners = atlas.image[y0 + 5 : y0 + 7, x0 + 3 : x0 + 5].astype(float)
    assert np.abs(got - corners.mean(axis=(0, 1))).max() < 1e-12


def test_inspect_lists_the_materials():
    out = cli("inspect", ATLAS)
    assert out.returncode == 0, out.stderr
    rect = load_table(ATLAS).slice_of("steel_werner")["rect"]
    assert "lutbake-atlas v1" in out.stdout and f"material steel_werner: rect {rect}" in out.stdout


def test_sample_by_material_name_from_the_command_line():
    out = cli("sample", ATLAS, "--material", "steel_werner", "--thickness", 40, "--angle", 30, "--json")
    assert out.returncode == 0, out.stderr
    row = json.loads(out.stdout)["points"][0]
    atlas = load_table(ATLAS)
    assert (
        row["rgb"]
        == atlas.sample("steel_werner", stack(atlas, "steel_werner", np.cos(np.radians(30)), 40.0))[0].tolist()
    )
    assert row["in_domain"] and abs(row["thickness_nm"] - 40) < 1e-12


@pytest.mark.parametrize(
    "args, message",
    [
        ((ATLAS,), "--material is required with a scene atlas: allowed steel_constant, steel_werner"),
        ((ATLAS, "--material", "gold"), "material 'gold' is not in this atlas"),
        ((ATLAS, "--material", "steel_werner", "--eta3", 2), "--eta3 is not allowed with a scene atlas"),
        ((LUT, "--material", "steel_werner", "--eta3", 2), "--material 'steel_werner' is for scene atlases"),
    ],
)
def test_sample_rejects_bad_atlas_input(args, message):
    out = cli("sample", *args, "--thickness", 40, "--angle", 30)
    assert out.returncode == 2 and message in out.stderr and out.stderr.count("\n") == 1 and not out.stdout


def test_report_scores_the_stored_atlas_and_gates(tmp_path):
    out = cli("report", ATLAS, "--points", 100, "--json", "--out", tmp_path / "rep", "--search-budget", 200)
    assert out.returncode == 0, out.stderr
    summary = json.loads(out.stdout)
    assert [s["materials"] for s in summary["slices"]] == [["steel_constant"], ["steel_werner"]]
    assert 0 < summary["lut_error"]["de00_p99"] <= 0.5  # the scene's max_de target, on the half bytes
    assert json.loads((tmp_path / "rep" / "summary.json").read_text()) == summary
    gated = cli("report", ATLAS, "--points", 100, "--max-de", 0.01, "--search-budget", 200)
    assert gated.returncode == 1 and "FAIL" in gated.stdout
