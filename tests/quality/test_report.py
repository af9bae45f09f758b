"""Reports: reproducible, find planted errors, gate correctly; approximation rows hand-checked."""

import copy
import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.lut.bake import bake
from lutbake.lut.sample import Lut
from lutbake.modes.approximations import belcour_barla_rgb, eval_sensitivity, khr_iridescence_rgb
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.measure import held_out_points, proxy_truth, remembered, search_max
from lutbake.quality.report import report_lut
from lutbake.spectral.reference import reference_colour
from lutbake.tables.lutfile import exr_stream


def _spec():
    axes = (
        Axis("cos_theta", 0.0, 1.0, 16, "sqrt"),
        Axis("opd_nm", 0.0, 2000.0, 48),
        Axis("eta3", 1.0, 3.0, 6),
        Axis("kappa3", 0.0, 4.0, 6, "sqrt"),
    )
    return BakeSpec(eta2=1.4, axes=axes)


@pytest.fixture(scope="module")
def lut_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("rep") / "lut.exr"
    bake(_spec(), path)
    return path


BUDGET = 2000  # each row's worst-case search: a tenth of `report`'s default, enough for these small grids


def test_numbers_are_reproducible_for_a_seed(lut_path):
    def numbers(seed):  # everything but timings (ns per evaluation), which vary by nature
        doc = report_lut(lut_path, 200, seed=seed, search_budget=BUDGET).summary()
        for row in [doc["lut_error"], *doc["approximations"]]:
            row.pop("ns_per_eval")
        return json.dumps(doc, sort_keys=True)

    assert numbers(3) == numbers(3)
    assert numbers(3) != numbers(4)


def test_planted_error_is_found_at_its_parameters(lut_path, tmp_path):
    """Perturb one tile (η3 node 3, κ3 node 2): the worst points lie in its neighbourhood."""
    lut = Lut.load(lut_path)
    image = lut.image.astype(np.float64)
    n_cos, n_opd = 16, 48
    image[2 * n_opd : 3 * n_opd, 3 * n_cos : 4 * n_cos] += 0.2
    planted = tmp_path / "planted.exr"
    with exr_stream(planted, image.shape[1], image.shape[0], lut.meta) as exr:
        exr.write_rows(image)
    rep = report_lut(planted, 600, seed=1, approximations=False, search_budget=BUDGET)
    eta3_nodes, kappa3_nodes = lut.axes[2].values(), lut.axes[3].values()

    def near_the_tile(w):
        return eta3_nodes[2] < w["eta3"] < eta3_nodes[4] and kappa3_nodes[1] < w["kappa3"] < kappa3_nodes[3]

    held = [w for w in rep.worst if not w["kind"].startswith("searched")]
    assert held and all(near_the_tile(w) for w in held[:5])  # (this grid's corner errs more: searched)
    clean = report_lut(lut_path, 600, seed=1, approximations=False, search_budget=BUDGET).lut.summary()
    planted_maxima = [m for m in rep.lut.worst_case["local_maxima"] if near_the_tile(m)]
    assert planted_maxima and max(m["de00"] for m in planted_maxima) > 2 * clean["worst_case"]["held_out_max"]
    assert rep.lut.summary()["worst_case"]["held_out_max"] > 2 * clean["worst_case"]["held_out_max"]


def _report_cli(*args):
    return subprocess.run([sys.executable, "-m", "lutbake.cli", "report", *args], capture_output=True, text=True)


def test_gate_exits_1_above_and_0_below_the_threshold(lut_path):
    p99 = report_lut(lut_path, 200, seed=0, approximations=False, search_budget=BUDGET).summary()["lut_error"][
        "de00_p99"
    ]
    flags = ("--points", "200", "--no-approximations", "--search-budget", str(BUDGET), "--json")
    above = _report_cli(str(lut_path), *flags, "--max-de", f"{p99 * 0.99}")
    below = _report_cli(str(lut_path), *flags, "--max-de", f"{p99 * 1.01}")
    assert above.returncode == 1 and json.loads(above.stdout)["gate"]["passed"] is False
    assert below.returncode == 0 and json.loads(below.stdout)["gate"]["passed"] is True


def test_report_writes_html_figures_and_summary(lut_path, tmp_path):
    out = _report_cli(
        str(lut_path),
        "--points",
        "100",
        "--out",
        str(tmp_path / "r"),
        "--max-de",
        "0.001",
        "--search-budget",
        str(BUDGET),
    )
    assert out.returncode == 1, out.stderr  # the gate fails, the report is written
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    rows = {a["name"]: a for a in summary["approximations"]}
    assert set(rows) == {
        "belcour-barla-2017",
        "khr-iridescence-threejs",
        "lutbake-exact-mode",
        "lutbake-runtime",
        "lut-linear-reads",
    }
    assert [r["name"] for r in summary["runtime_paths"]] == ["lut", *rows]  # each row's error beside its cost
    # the LUT is read cubic (its header's rule); linear reads of the same texels err more
    assert summary["interpolation"] == "cubic"
    assert summary["lut_error"]["de00_p99"] < rows["lut-linear-reads"]["de00_p99"]
    # the exact runtime mode: within its engine test's bound (ΔE00 0.1), well below the approximations
    assert rows["lutbake-exact-mode"]["de00_max"] <= 0.1 < rows["belcour-barla-2017"]["de00_p99"]
    terms = summary["exact_mode_terms"]
    assert 1 <= terms["mean"] <= terms["p99"] <= terms["max"] <= 64
    html = (tmp_path / "r" / "report.html").read_text()
    assert "Gate FAIL" in html and "η2 = 1.4" in html and summary["gate"]["passed"] is False
    for fig in summary["figures"]:
        assert (tmp_path / "r" / fig).stat().st_size > 1000 and fig in html
    # the table, the JSON and the terminal state one max: the searched one (the maps' agreement: below)
    lut_row = summary["lut_error"]
    assert (
        "<td>lut</td>"
        + "".join(f"<td>{lut_row[k]:.3f}</td>" for k in ("de00_mean", "de00_p50", "de00_p95", "de00_p99", "de00_max"))
        in html
    )
    assert f"{lut_row['de00_max']:.3f} at cos θ" in html and f"ΔE00 {lut_row['de00_max']:.3f} at" in out.stdout
    assert lut_row["de00_max"] == lut_row["worst_case"]["de00_max"] >= lut_row["worst_case"]["held_out_max"]


def test_the_truth_has_no_limit_at_the_corner_and_corner_distance_measures_the_way_there():
    """Ground truth along three rays into cos θ1, D, η3 − η1, κ3 → 0 (η1 = 1, η2 1.33, η3 = η1, κ3 = 0),
    (cos θ1, D) shrinking by a common factor s: R keeps a constant on each ray — 0 with no film, 0.372 with
    D = 600·cos θ1 nm, 0.998 with D = 20000·cos θ1 nm — so it has no limit at the corner; measure.corner_distance
    falls as s."""
    from lutbake.quality.measure import corner_distance

    s = np.array([1e-3, 1e-4, 1e-5])
    limits = []
    for slope in (0.0, 600.0, 20000.0):
        ray = FilmPoints.build(eta2=1.33, cos_theta=s, opd_nm=slope * s, eta3=1.0, kappa3=0.0)
        r = reference_colour(ray).values[:, 1]
        assert np.ptp(r) < 1e-5
        limits.append(r[-1])
        rho = corner_distance(ray)
        assert np.allclose(rho[1:] / rho[:-1], 0.1, rtol=1e-3) and rho[0] < 0.07
    assert limits[0] < 1e-12 and abs(limits[1] - 0.372) < 1e-3 and limits[2] > 0.99


def _corner_lut(tmp_path_factory):
    """A soap-film LUT on the default set's dielectric parameterization, small: it reaches the corner where
    cos θ1, D, η3 − η1 and κ3 all vanish."""
    axes = (
        Axis("cos_theta", 0.0, 1.0, 12, "sqrt"),
        Axis("opd_nm", 0.0, 1200.0, 24, "sqrt"),
        Axis("eta3", 1.0, 2.0, 6, "sqrt-admittance"),
        Axis("kappa3", 0.0, 1.0, 5, "root4"),
    )
    path = tmp_path_factory.mktemp("corner") / "soap.exr"
    bake(BakeSpec(eta2=1.33, axes=axes), path)
    return path


@pytest.fixture(scope="module")
def corner_report(tmp_path_factory):
    return report_lut(_corner_lut(tmp_path_factory), 300, seed=0, approximations=False, search_budget=4000)


def test_the_searched_max_is_found_where_held_out_points_do_not_reach_and_holds_against_the_truth(corner_report):
    """The max is searched: well above the held-out points' largest, at the place where the content is
    singular; the ΔE00 it states is the ground truth's (recomputed here), and its local maxima are listed."""
    rep = corner_report
    worst = rep.lut.summary()["worst_case"]
    assert worst["de00_max"] > 3 * worst["held_out_max"]
    assert worst["found_by"].startswith(("singular: ", "near singular: "))
    stack = FilmPoints.build(
        eta2=1.33, cos_theta=worst["cos_theta"], opd_nm=worst["opd_nm"], eta3=worst["eta3"], kappa3=worst["kappa3"]
    )
    lut = Lut.load(rep.path)
    truth = reference_colour(stack).values
    assert np.allclose(truth[0], worst["truth_rgb"], atol=1e-9) and np.allclose(lut.sample(stack)[0], worst["lut_rgb"])
    assert delta_e00(lut.sample(stack), truth)[0] == pytest.approx(worst["de00_max"], rel=1e-9)
    assert rep.worst[0]["de00"] == worst["de00_max"] and rep.worst[0]["kind"].startswith("searched: ")
    assert len(worst["local_maxima"]) >= 5 and worst["evaluations"] <= 4000


def test_maps_never_show_more_than_the_stated_max(corner_report, tmp_path):
    """The ΔE00 maps are drawn after their points have joined the max: every map value is at most the max
    the table and JSON state, and a map point above a max the search missed becomes the max
    (``include_points``, planted here by lowering the searched max)."""
    from lutbake.quality.figures import delta_e_map_panels

    rep = corner_report
    panels = delta_e_map_panels(rep, n=16)
    stated = rep.lut.summary()["de00_max"]
    assert max(p.de00.max() for p in panels) <= stated
    missed = copy.deepcopy(rep)
    missed.lut.worst_case["de00_max"] = 0.0  # as if the search had found nothing
    top = max(panels, key=lambda p: p.de00.max())
    missed.include_points(top.stack, top.truth, top.de00.ravel(), "map point")
    assert missed.lut.summary()["de00_max"] >= top.de00.max() > 0.0


def test_report_bad_input_exits_2(tmp_path):
    assert _report_cli(str(tmp_path / "missing.exr")).returncode == 2
    (tmp_path / "not.exr").write_bytes(b"nope")
    assert _report_cli(str(tmp_path / "not.exr")).returncode == 2


def test_gaussian_fit_normalization_by_hand():
    """S(0) from the published constants: val·√(2π·var)/1.0685e-7 (+ the second X lobe)."""
    x = (5.4856e-13 * math.sqrt(2 * math.pi * 4.3278e9) + 9.7470e-14 * math.sqrt(2 * math.pi * 4.5282e9)) / 1.0685e-7
    y = 4.4201e-13 * math.sqrt(2 * math.pi * 9.3046e9) / 1.0685e-7
    z = 5.2481e-13 * math.sqrt(2 * math.pi * 6.6121e9) / 1.0685e-7
    assert np.allclose(eval_sensitivity(0.0, 0.0), [x, y, z], rtol=1e-12)
    assert np.allclose([x, y, z], 1.0, atol=1.2e-3)  # the fit's white is E, to 0.1%
    assert np.allclose(eval_sensitivity(0.0, np.pi), -eval_sensitivity(0.0, 0.0))


def _stack(eta2, eta3, kappa3, cos_theta, opd):
    return FilmPoints.build(eta2=eta2, cos_theta=cos_theta, opd_nm=opd, eta3=eta3, kappa3=kappa3)


def _truth(stack):
    return reference_colour(stack).values


def test_belcour_barla_matches_the_exact_integral_at_zero_thickness():
    cos_t = np.array([1.0, 0.8, 0.5, 0.2])
    for eta3 in (1.0, 1.5, 2.4):
        bare = _stack(1.5, eta3, 0.0, cos_t, 0.0)
        assert delta_e00(belcour_barla_rgb(bare), _truth(bare)).max() < 0.1


def test_approximations_refuse_named_materials():
    """They take one constant index per layer: a dispersive base is the ground truth's to evaluate."""
    copper = FilmPoints.build(eta2=1.5, cos_theta=0.9, thickness_nm=200.0, base="Cu")
    for method in (belcour_barla_rgb, khr_iridescence_rgb):
        with pytest.raises(ParameterError, match=r"^base 'Cu' differs from the .*'s base = None$"):
            method(copper)


def test_belcour_barla_fails_on_dispersive_metal_bases():
    """A constant-index evaluation cannot follow a conductor whose phase varies with wavelength
    (Cycles' finding): copper fails by ΔE > 10, silver (flat dispersion) stays below 1.5."""
    from lutbake.physics.materials import material

    opd = np.linspace(100.0, 1500.0, 40)

    def de(base):
        eta3, kappa3 = (float(v) for v in material(base).index(550.0))
        truth = reference_colour(FilmPoints.build(eta2=1.5, cos_theta=0.9, thickness_nm=opd / 3.0, base=base)).values
        return delta_e00(belcour_barla_rgb(_stack(1.5, eta3, kappa3, 0.9, opd)), truth)

    assert np.percentile(de("Cu"), 50) > 10
    assert np.percentile(de("Ag"), 90) < 1.5


def test_khr_hand_computed_value_on_bare_glass():
    """η2 = η1 (film fades out), glass base, normal incidence, by hand with three.js's Schlick (its exp2 fit:
    f = 2^(−5.55473 − 6.98316) at cos 1, not 0): R12 = f, R23 = 0.04 + 0.96 f, R123 clamped to 1e-5,
    C0 = R12 + Rs, orders ±2 (Rs − T121) R123^(m/2) (M709 · S(0)) (phase π per order)."""
    m709 = np.array(
        [[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]]
    )
    s0 = eval_sensitivity(0.0, 0.0)
    f = 2.0 ** (-5.55473 - 6.98316)
    rs = (1 - f) ** 2 * (0.04 + 0.96 * f) / (1 - 1e-5)
    expected = f + rs - 2 * (rs - (1 - f)) * math.sqrt(1e-5) * (m709 @ s0) + 2 * (rs - (1 - f)) * 1e-5 * (m709 @ s0)
    assert np.allclose(khr_iridescence_rgb(_stack(1.0, 1.5, 0.0, 1.0, 0.0)), expected, atol=1e-6)
    assert np.allclose(m709 @ np.ones(3), [1.2048, 0.9484, 0.9088], atol=1e-4)  # its white cast


def test_khr_loses_the_base_extinction():
    """Bases with one F0 but different (η3, κ3) look alike to KHR, not to the ground truth."""
    f0 = ((2.7 - 1) ** 2 + 2.8**2) / ((2.7 + 1) ** 2 + 2.8**2)
    eta3_dielectric = (1 + math.sqrt(f0)) / (1 - math.sqrt(f0))
    metal, dielectric = _stack(2.0, 2.7, 2.8, 0.9, 600.0), _stack(2.0, eta3_dielectric, 0.0, 0.9, 600.0)
    assert np.allclose(khr_iridescence_rgb(metal), khr_iridescence_rgb(dielectric), atol=1e-12)
    assert delta_e00(_truth(metal), _truth(dielectric)).max() > 5


def test_sweep_and_tune_on_a_small_domain(tmp_path):
    from lutbake.quality.refine import tune
    from lutbake.quality.sweep import sweep

    axes = (
        Axis("cos_theta", 0.3, 1.0, 8),
        Axis("opd_nm", 0.0, 800.0, 16),
        Axis("eta3", 1.4, 1.6, 4),
        Axis("kappa3", 0.0, 0.5, 4),
    )
    spec = BakeSpec(eta2=1.33, axes=axes)
    doc = sweep(spec, tmp_path / "s", n_points=120, seed=0, search_budget=300)
    kinds = [r["kind"] for r in doc["rows"]]
    assert kinds.count("lut") >= 8 and kinds.count("approximation") == 4  # two approximations, the exact mode, runtime
    assert (tmp_path / "s" / "pareto.png").stat().st_size > 1000
    res = {r["name"]: r for r in doc["rows"]}
    assert res["res×2"]["de00_p99"] < res["res×0.5"]["de00_p99"]
    assert res["res×2"]["bytes"] > res["res×0.5"]["bytes"]
    assert res["uniform grid"]["shape"] == res["√ grid"]["shape"] == res["res×1"]["shape"]
    assert res["uniform grid"]["de00_p99"] == res["res×1"]["de00_p99"]  # this spec's axes are all uniform
    assert res["√ grid"]["de00_p99"] != res["uniform grid"]["de00_p99"]
    assert res["admittance grid"]["shape"] == res["res×1"]["shape"]  # η3 1.4–1.6 ≥ η1: it is there
    assert res["admittance grid"]["de00_p99"] != res["√ grid"]["de00_p99"]
    assert res["res×1 linear reads"]["bytes"] == res["res×1"]["bytes"]  # same file, read by the other rule
    assert res["res×1"]["de00_p99"] < res["res×1 linear reads"]["de00_p99"]
    result = tune(spec, max_de=0.2, n_points=120, seed=0, search_budget=300)
    assert result.met and result.best.de00_p99 <= 0.2
    assert result.rounds[0].de00_p99 > 0.2  # the search had to grow the grid


def test_atlas_slices_report_their_searched_max():
    """A scene atlas (the tempered-steel example, baked here): each slice's max is searched over its
    (√cos θ, thickness) grid against the ground truth; the atlas row's max is the largest slice's."""
    import sys

    from lutbake.lut.sample import Atlas
    from lutbake.quality.report import report_atlas

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "docs"))
    from make_scene_examples import bake_example

    path = bake_example("tempered-steel") / "tempered-steel.exr"
    doc = report_atlas(Atlas.load(path), path, n_points=100, search_budget=300)
    for s in doc["slices"]:
        w = s["worst_case"]
        assert s["de00_max"] == w["de00_max"] >= w["held_out_max"] and w["evaluations"] <= 300
        stack = FilmPoints.build(
            cos_theta=w["cos_theta"], thickness_nm=w["thickness_nm"], **Atlas.load(path).film_stack(s["materials"][0])
        )
        truth = reference_colour(stack).values
        assert delta_e00(Atlas.load(path).sample(s["materials"][0], stack), truth)[0] == pytest.approx(w["de00_max"])
    assert doc["lut_error"]["de00_max"] == max(s["de00_max"] for s in doc["slices"])


def test_tuned_counts_pass_report_at_three_seeds_tune_never_saw(tmp_path):
    """`tune --max-de 0.3` holds the 99.73th percentile of report's kinds of points to 0.3; the file baked at
    its counts passes `report --max-de 0.3` (1,000 points, its default) at seeds 4, 5 and 6. (Holding their
    p99 instead, tune stops at 32×32×4×8, which seed 4 fails: p99 0.318.)"""
    from lutbake.quality.refine import tune

    axes = (
        Axis("cos_theta", 0.0, 1.0, 8, "sqrt"),
        Axis("opd_nm", 0.0, 1500.0, 16),
        Axis("eta3", 1.2, 2.0, 4, "sqrt-admittance"),
        Axis("kappa3", 0.0, 0.5, 4, "sqrt"),
    )
    spec = BakeSpec(eta2=1.33, axes=axes, precision="half")
    result = tune(spec, 0.3, search_budget=BUDGET)
    assert result.met and result.best.gated <= 0.3 and result.best.de00_p99 <= result.best.gated
    tuned = BakeSpec(eta2=1.33, axes=tuple(replace(a, count=c) for a, c in zip(axes, result.counts)), precision="half")
    bake(tuned, tmp_path / "tuned.exr")
    out = _report_cli(
        str(tmp_path / "tuned.exr"),
        "--seed",
        "4",
        "--max-de",
        "0.3",
        "--no-approximations",
        "--search-budget",
        str(BUDGET),
        "--json",
    )
    assert out.returncode == 0, json.loads(out.stdout)["lut_error"]["de00_p99"]
    for seed in (5, 6):  # the same gate through the API (report --max-de X passes when p99 <= X)
        rep = report_lut(tmp_path / "tuned.exr", seed=seed, approximations=False, search_budget=BUDGET)
        assert rep.lut.summary()["de00_p99"] <= 0.3, seed
    worst = result.best.stats["worst_case"]  # its max is searched, as report's
    assert result.best.stats["de00_max"] == worst["de00_max"] >= worst["held_out_max"]


def test_cell_centre_points_sit_at_cell_centres_of_an_admittance_grid():
    """Held-out 'cell-centre' points are at half-integer node coordinates on every axis, η3's taken in its
    admittance coordinate at the point's own cos θ (what the sampler interpolates in)."""
    from lutbake.quality.measure import held_out_points

    axes = (
        Axis("cos_theta", 0.0, 1.0, 8, "sqrt"),
        Axis("opd_nm", 0.0, 2000.0, 8),
        Axis("eta3", 1.0, 3.0, 5, "admittance"),
        Axis("kappa3", 0.0, 4.0, 4, "sqrt"),
    )
    pts = held_out_points(axes, 1.0, 1.4, "cie1931", "rec709", 40, 3)
    centre = pts.kind == "cell-centre"
    lut = Lut({"axes": [a.describe() for a in axes], "constants": {"eta1": 1.0, "eta2": 1.4}}, None)
    coords = np.stack(lut.node_coords(pts.stack), axis=1)[centre]
    assert np.allclose(coords % 1.0, 0.5, atol=1e-9)
    uniform_eta3 = Axis("eta3", 1.0, 3.0, 5).to_unit(pts.stack.eta3[centre]) * 4
    assert not np.allclose(uniform_eta3 % 1.0, 0.5, atol=1e-3)  # the admittance cells are not η3's


def test_rows_integrate_the_truth_once_at_their_common_starts_and_search_as_before(lut_path):
    """Two rows' searches through one remembered proxy: the same searched maxima as through the proxy
    itself, with fewer stacks integrated (the rows' corners, edges, faces and scatter are shared)."""
    lut = Lut.load(lut_path)
    axes, meta = lut.axes, lut.meta
    pts = held_out_points(axes, lut.eta1, lut.eta2, meta["observer"], meta["space"], 40, seed=0)
    rows = {
        "lut": lambda stack: lut.sample(stack),
        "khr": lambda stack: khr_iridescence_rgb(stack, meta["space"], meta["observer"]),
    }
    integrated = {"direct": 0, "remembered": 0}

    def counting(name):
        truth = proxy_truth(lut, backend="numpy")

        def read(stack):
            integrated[name] += len(stack)
            return truth(stack)

        return read

    found = {}
    for name, proxy in (("direct", counting("direct")), ("remembered", remembered(counting("remembered")))):
        found[name] = [
            search_max(
                read,
                lut,
                pts,
                delta_e00(read(pts.stack), pts.truth, meta["observer"], meta["space"]),
                proxy,
                BUDGET,
                seed=1,
            )
            for read in rows.values()
        ]
    assert found["remembered"] == found["direct"]
    assert integrated["remembered"] < 0.8 * integrated["direct"]
