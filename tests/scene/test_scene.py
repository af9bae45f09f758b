"""Scene-driven bakes: validation, axis collapse, dispersive accuracy, incremental re-bakes."""

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from lutbake.integrate.opencl import backend
from lutbake.lut.sample import load_table
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.refine import Trial, bound_level, mixture_percentile, refine
from lutbake.scene.bake import bake_scene
from lutbake.scene.jobs import uniform_points
from lutbake.scene.plan import plan_scene
from lutbake.scene.slices import DISPERSIVE_TOLERANCE, SliceStack, integrate_slice, slice_grid
from lutbake.scene.toml import load_scene
from lutbake.spectral.reference import reference_colour


def write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


FIXED_BASES = """
[scene]
max_de = 2.0

[materials.soap]
film = 1.33
thickness_nm = [200, 500]
base = 1.0

[materials.bubble_copy]   # same film, thickness and base: shares the soap slice
film = 1.33
thickness_nm = [200, 500]
base = 1.0

[materials.steel]
film = 2.9
thickness_nm = [10, 70]
base = { eta3 = 2.7, kappa3 = 2.8 }
"""


def test_fixed_base_scene_collapses_to_small_2d_slices(tmp_path):
    plan = plan_scene(load_scene(write(tmp_path, FIXED_BASES)))
    assert [j.kind for j in plan.jobs] == ["slice", "slice"]
    assert plan.jobs[0].materials == ["soap", "bubble_copy"]
    doc = plan.describe()
    assert all(len(j["counts"]) == 2 for j in doc["jobs"])
    assert doc["bytes_start_total"] * 100 < doc["generic_4d_bytes"]
    ranged = plan_scene(
        load_scene(
            write(
                tmp_path,
                """
        [materials.coat]
        film = 1.6
        thickness_nm = [150, 450]
        base = { eta3 = [1.2, 2.8], kappa3 = [0.5, 4.0] }
        """,
                "ranged.toml",
            )
        )
    )
    assert [j.kind for j in ranged.jobs] == ["lut"]
    assert [a["min"] for a in ranged.describe()["jobs"][0]["axes"]][2:] == [1.2, 0.5]


def test_fixed_thickness_collapses_to_one_row(tmp_path):
    plan = plan_scene(
        load_scene(
            write(
                tmp_path,
                """
        [materials.ergun_1]
        film = 3.0
        thickness_nm = 15.1667
        base = { eta3 = 1.43, kappa3 = 0.0 }
        """,
            )
        )
    )
    assert plan.jobs[0].counts[1] == 1


def test_dispersive_copper_slice_meets_the_target_against_ground_truth(tmp_path):
    scene = load_scene(
        write(
            tmp_path,
            """
        [scene]
        max_de = 0.4

        [materials.copper_coat]
        film = 1.5
        thickness_nm = [100, 300]
        base = "Cu"
        """,
        )
    )
    result = bake_scene(scene, tmp_path / "out")
    manifest = json.loads((tmp_path / "out" / "scene.json").read_text())
    entry = manifest["materials"]["copper_coat"]
    atlas = load_table(tmp_path / "out" / "scene.exr")  # the half values as shipped
    rng = np.random.default_rng(11)  # fresh points, not the ones the bake refined against
    cos_t, d = rng.uniform(0, 1, 300), rng.uniform(100, 300, 300)
    coat = FilmPoints.build(eta2=1.5, cos_theta=cos_t, thickness_nm=d, base="Cu")
    de = delta_e00(atlas.sample("copper_coat", coat), reference_colour(coat).values)
    assert np.percentile(de, 99) <= 0.5
    assert entry["constant_index_de00_p99"] > 5 * entry["de00_p99"]  # a constant index is far off
    assert result.computed == [entry["job"]]


def test_unchanged_scene_writes_nothing_and_one_change_rebakes_one_slice(tmp_path):
    scene_path = write(tmp_path, FIXED_BASES)
    out = tmp_path / "out"
    first = bake_scene(load_scene(scene_path), out)
    assert len(first.computed) == 2
    stamps = {p.name: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    again = bake_scene(load_scene(scene_path), out)
    assert again.up_to_date and again.written == []
    assert stamps == {p.name: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    scene_path.write_text(FIXED_BASES.replace("[10, 70]", "[10, 80]"))
    touched = bake_scene(load_scene(scene_path), out)
    assert len(touched.computed) == 1 and len(touched.reused) == 1
    soap = json.loads((out / "scene.json").read_text())["materials"]["soap"]["job"]
    cache = out / ".lutbake-cache"
    assert (cache / f"{soap}.npy").stat().st_mtime_ns == stamps[f"{soap}.npy"]
    forced = bake_scene(load_scene(scene_path), out, force=True)
    assert len(forced.computed) == 2


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", *args], capture_output=True, text=True)


@pytest.mark.parametrize(
    "text, message",
    [
        (
            "[materials.a]\nfilm = 1.5\nthickness_nm = [10, 70]\nbase = 1.0\ncolour = 'red'\n",
            ":5: unknown field materials.a.colour",
        ),
        ("[materials.a]\nfilm = 1.5\nbase = 1.0\n", ":1: materials.a is missing the field 'thickness_nm'"),
        (
            "[materials.a]\nfilm = 1.5\nthickness_nm = [70, 10]\nbase = 1.0\n",
            ":3: materials.a.thickness_nm = [70, 10] is reversed",
        ),
        (
            '[materials.a]\nfilm = 1.5\nthickness_nm = [10, 70]\nbase = "Cooper"\n',
            ":4: materials.a.base: unknown material 'Cooper'",
        ),
        (
            "[materials.a]\nfilm = 1.5\nthickness_nm = 10\nbase = { eta3 = 2.0, kappa3 = -1 }\n",
            ":4: materials.a.kappa3",
        ),
        (
            "[scene]\nspace = 'srgb'\n[materials.a]\nfilm = 1.5\nthickness_nm = 10\nbase = 1.0\n",
            ":2: scene.space = 'srgb'",
        ),
        (
            '[materials.a]\nfilm = "butanol"\nthickness_nm = 10\nbase = { eta3 = [1, 2] }\n',
            ":2: materials.a: a named (dispersive) film",
        ),
        ("[materials.a\nfilm = 1.5\n", "invalid TOML"),
        (
            "[materials.a]\nfilm = nan\nthickness_nm = 10\nbase = 1.0\n",
            ":2: materials.a.film: eta2 = nan is not allowed",
        ),
        (
            "[materials.a]\nfilm = 1.5\nthickness_nm = [10, 1e400]\nbase = 1.0\n",
            ":3: materials.a.thickness_nm: thickness_nm = inf is not allowed",
        ),
    ],
)
def test_invalid_scenes_exit_2_naming_file_line_and_field(tmp_path, text, message):
    path = write(tmp_path, text)
    out = tmp_path / "out"
    for args in (["bake", "--scene", str(path), "--out", str(out)], ["plan", "--scene", str(path)]):
        proc = _cli(*args)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and str(path) in lines[0] and message in lines[0]
    assert not out.exists()


def test_plan_and_bake_from_the_command_line(tmp_path):
    path = write(tmp_path, FIXED_BASES)
    plan = _cli("plan", "--scene", str(path), "--json")
    assert plan.returncode == 0 and len(json.loads(plan.stdout)["jobs"]) == 2
    assert not (tmp_path / "out").exists()
    baked = _cli("bake", "--scene", str(path), "--out", str(tmp_path / "out"), "--json")
    assert baked.returncode == 0, baked.stderr
    files = {p.name for p in (tmp_path / "out").iterdir()}
    assert {"scene.exr", "scene.json", "scene.glsl", "scene.hlsl"} <= files
    glsl = (tmp_path / "out" / "scene.glsl").read_text()
    assert "const LutbakeSlice LUTBAKE_SCENE_SOAP =" in glsl and "LUTBAKE_SCENE_STEEL =" in glsl
    hlsl = (tmp_path / "out" / "scene.hlsl").read_text()
    assert "static const LutbakeSlice LUTBAKE_SCENE_SOAP =" in hlsl and "SampleLevel(linear_clamp" in hlsl


def test_ranged_base_gets_a_4d_lut_tuned_to_the_target(tmp_path):
    scene = load_scene(
        write(
            tmp_path,
            """
        [scene]
        max_de = 1.5

        [materials.coat]
        film = 1.6
        thickness_nm = [150, 300]
        base = { eta3 = [1.2, 2.0], kappa3 = [0.5, 2.0] }
        """,
        )
    )
    result = bake_scene(scene, tmp_path / "out")
    entry = json.loads((tmp_path / "out" / "scene.json").read_text())["materials"]["coat"]
    assert entry["kind"] == "lut" and entry["de00_p99"] <= 1.5
    from lutbake.lut.sample import Lut

    lut = Lut.load(tmp_path / "out" / entry["file"])
    assert [a.count for a in lut.axes] == entry["counts"]
    assert (lut.axes[2].lo, lut.axes[2].hi, lut.axes[3].lo, lut.axes[3].hi) == (1.2, 2.0, 0.5, 2.0)
    assert result.computed == [entry["job"]]
    assert bake_scene(scene, tmp_path / "out").up_to_date


@pytest.mark.parametrize("centres", [False, True], ids=["nodes", "cell centres"])
@pytest.mark.parametrize(
    "film, base, thickness_nm, tolerance",
    [
        (1.33, (1.0, 0.0), (100, 1000), 1e-8),  # constant indices: the kernel's 4D path, series per texel
        (3.0, (1.43, 0.0), (15.1667, 15.1667), 1e-8),  # one thickness row
        (2.9, "Fe", (10, 70), DISPERSIVE_TOLERANCE),  # dispersive base: the kernel's reflectance per node
        ("butanol", "Ag", (100, 600), DISPERSIVE_TOLERANCE),  # dispersive film: numpy per node; silver's kinks
    ],
)
def test_slice_integration_matches_the_ground_truth_at_its_texels(film, base, thickness_nm, tolerance, centres):
    """At the slice's nodes and at its cells' centres (what a slice's trials are scored against)."""
    from lutbake.integrate.opencl import backend

    stack, counts = SliceStack(1.0, film, base), (24, 1 if thickness_nm[0] == thickness_nm[1] else 12)
    values = integrate_slice(stack, counts, thickness_nm, backend(), "cie1931", "rec709", centres=centres)
    cos_values, d = slice_grid(counts, thickness_nm, centres=centres)
    assert values.shape == (d.size, cos_values.size, 3)
    cos_t, dd = (g.ravel() for g in np.meshgrid(cos_values, d))
    pick = np.random.default_rng(3).choice(cos_t.size, min(24, cos_t.size), replace=False)
    truth = reference_colour(stack.points(cos_t[pick], dd[pick]), tolerance=1e-9).values
    assert np.max(np.abs(values.reshape(-1, 3)[pick] - truth)) <= tolerance


@pytest.mark.parametrize("compute, tolerance", [("float64", 1e-12), ("float32", 2e-5)])
@pytest.mark.parametrize(
    "eta1, film, base",
    [
        (1.0, "butanol", "Ag"),  # dispersive film over a dispersive metal
        (1.0, 2.9, "Fe"),  # constant film, dispersive base
        (1.6, "butanol", "TiO2"),  # η1 > η2: the film is evanescent beyond its critical angle (R < 1 over TiO2)
    ],
)
def test_stack_colour_matches_the_numpy_physics_node_by_node(kernel_device, compute, tolerance, eta1, film, base):
    """The device's per-stack sum (stack_terms + stack_rgb) against lutbake/physics/optics.py's R at the same rule's
    nodes, at grazing and normal incidence, zero and thick films, and cos θ1 repeated across points
    (the Fresnel side is shared per distinct cos θ1)."""
    from lutbake.integrate.opencl import OpenCLBackend
    from lutbake.spectral.reference import spectral_reflectance
    from lutbake.spectral.rules import rule_ladder

    stack = SliceStack(eta1, film, base)
    cos_t = np.array([0.0, 1e-6, 0.01, 0.3, 0.3, 0.3, 0.77, 1.0, 1.0])
    d = np.array([300.0, 600.0, 5000.0, 0.0, 120.0, 20000.0, 450.0, 0.0, 1000.0])
    points = stack.points(cos_t, d)
    rule = rule_ladder().rule(4)
    device = OpenCLBackend(compute, device=kernel_device)
    node_indices = [v.ravel() for v in stack.points(1.0, 0.0).indices(rule.wavelength_nm)]
    got = device.stack_colour(eta1, cos_t, d, node_indices, rule)
    expected = spectral_reflectance(points, rule.wavelength_nm)[2] @ rule.weights.T
    assert np.max(np.abs(got - expected)) <= tolerance
    # grazing: R = 1, so both sides sum the N weights, each in some order: within γ_N Σ|w| apiece
    n = rule.wavelength_nm.size
    assert (
        np.abs(got[0] - rule.weights.sum(axis=1)) <= 2 * n * np.finfo(float).eps / 2 * np.abs(rule.weights).sum(axis=1)
    ).all()


def test_slice_error_is_measured_on_the_stored_atlas(tmp_path):
    """The manifest's p99 is what the shipped half texels score at the slice's uniform points and every cell
    centre (equal weight, as `report` draws them), and it holds at fresh points against the ground truth."""
    scene = load_scene(
        write(
            tmp_path,
            """
        [materials.steel]
        film = 2.9
        thickness_nm = [10, 70]
        base = { eta3 = 2.7, kappa3 = 2.8 }
        """,
        )
    )
    bake_scene(scene, tmp_path / "out")
    entry = json.loads((tmp_path / "out" / "scene.json").read_text())["materials"]["steel"]
    job, integrator = plan_scene(scene).jobs[0], backend("auto")
    stack, stored = job.stack(), load_table(tmp_path / "out" / "scene.exr")
    pts, truth = uniform_points(job, stack, integrator)
    counts = [entry["axes"][axis]["count"] for axis in ("cos_theta", "thickness_nm")]
    cos_c, d_c = (g.ravel() for g in np.meshgrid(*slice_grid(counts, job.thickness_nm, centres=True)))
    centres = stack.points(cos_c, d_c)
    de = [
        delta_e00(stored.sample("steel", p), t) for p, t in ((pts, truth), (centres, reference_colour(centres).values))
    ]
    assert entry["de00_p99"] == pytest.approx(mixture_percentile(de, 99.0), abs=2e-3)
    assert entry["target_met"] and entry["de00_p99"] <= entry["de00_p99_bound"] <= scene.max_de
    rng = np.random.default_rng(2024)  # not a seed the bake scored at
    fresh = stack.points(rng.uniform(0, 1, 1000) ** 2, rng.uniform(10, 70, 1000))
    assert np.percentile(delta_e00(stored.sample("steel", fresh), reference_colour(fresh).values), 99) <= scene.max_de
    assert entry["de00_max"] >= entry["worst_case"]["held_out_max"] >= entry["de00_p99"]
    float64 = np.load(tmp_path / "out" / ".lutbake-cache" / f"{entry['job']}.npy")
    assert not np.array_equal(float64.astype(np.float16).astype(float), float64)  # rounding is real


def _synthetic(error_per_axis):
    """A measure whose p99 is a sum of per-axis terms falling as 1/count (bytes: the texel count)."""
    seen = []

    def measure(counts, label):
        seen.append(counts)
        p99 = sum(e / c for e, c in zip(error_per_axis, counts))
        return Trial(counts, p99, int(np.prod(counts)), 0.0), f"grid {counts}"

    return measure, seen


def test_mixture_percentile_weighs_each_sample_equally_and_the_bound_level_is_report_s():
    """Two samples of 3 and 6 values: the equal-weight mixture is the 3 repeated twice beside the 6, whose
    inverted-CDF percentile numpy gives; 1,000 report points put the bound at the 99.73rd percentile."""
    a, b = np.array([5.0, 1.0, 3.0]), np.array([0.5, 2.0, 4.0, 6.0, 2.5, 7.0])
    for q in (10.0, 50.0, 90.0, 99.0, 99.73):
        assert mixture_percentile([a, b], q) == np.percentile(np.concatenate([a, a, b]), q, method="inverted_cdf")
    assert bound_level(1000) == pytest.approx(99.7319, abs=1e-4) and bound_level(10**9) == pytest.approx(99.0, abs=1e-3)


def test_refine_grows_the_axis_that_pays_most_per_byte_then_trims():
    measure, seen = _synthetic((8.0, 1.0))
    result = refine(measure, (4, 4), 1.2)
    assert result.met and result.best.de00_p99 <= 1.2
    assert [t.counts for t in result.rounds[:3]] == [(4, 4), (8, 4), (16, 4)]  # axis 0 carries the error
    assert (4, 8) in seen and (8, 8) in seen  # each round tried both axes
    assert result.counts == (12, 3)  # then each axis cut by a quarter while the target held
    assert result.artefact == "grid (12, 3)"  # what measure built for the best trial


def test_refine_respects_frozen_axes_and_the_cap():
    measure, seen = _synthetic((8.0, 8.0))
    result = refine(measure, (4, 1), 0.01, frozen=(1,), cap=32)
    assert not result.met and result.counts == (32, 1)
    assert all(c[1] == 1 and c[0] <= 32 for c in seen)
