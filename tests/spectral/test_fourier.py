"""The Fourier-series integrator (lutbake.spectral.fourier) against independent references."""

import io

import numpy as np
import pytest
from airy_mp import airy_reflectance_mp
from long_quadrature import LONG, U_DOUBLE, U_LONG, BandRule

from lutbake.physics.points import FilmPoints
from lutbake.spectral import fourier
from lutbake.spectral.fourier import series_coefficients, series_colour, weight_transform
from lutbake.spectral.reference import reference_colour
from lutbake.spectral.rules import panel_rule


def _transform_by_panels(x_nm, nodes_per_nm=64):
    """Ŵ_c(x) from the ground truth's own Gauss–Legendre panel rule, far finer than the table's."""
    rule = panel_rule(nodes_per_nm)
    return np.exp(2j * np.pi * np.outer(x_nm, 1.0 / rule.wavelength_nm)) @ rule.weights.T


def _transform_in_long_double(x_nm):
    """Ŵ_c(x) = ∫ w_c e^{i2πx/λ} dλ by BandRule (32 nodes on each 1 nm panel: converged, the phase turns
    at most 19 rad per nm), (n, 3), and its rounding bound: the phase 2πx/λ within 5u of it (2π, ·x,
    /λ, the node's move), e^{iφ} within 8u."""
    rule = BandRule()
    out = [
        rule.integral(np.exp(1j * phase), U_LONG * (5 * phase + 8))
        for phase in (rule.two_pi * LONG(x) / rule.nm for x in x_nm)
    ]
    return tuple(np.array(v) for v in zip(*out))


def _table_rounding(wt, x_nm):
    """A first-order bound (n,) on the weight table's float64 rounding at x beyond its interpolation bound
    (lutbake/spectral/fourier.py): its samples sum N nodes' w e^{i2πx(ν − ν0)} (the phase within 3u of 2πxν,
    two exps within 8u each, their product √5u; the sum γ_N), all ≤ ∫|w|, and its quintic Hermite read,
    whose value basis sums to 1 (derivative terms add < 20%), rounds 10u more, its modulation
    e^{i2πν0x} (phase within 3u, exp 8u, the product √5u) 13u more: ≤ u ∫|w| (1.2 (6·2πx/360 + 19 + N)
    + 23) with 2πν0x ≤ 2πx/360."""
    nodes = fourier._panel_nodes(wt.x_max_nm)[0].size
    return U_DOUBLE * wt.mass.max() * (1.2 * (6 * 2 * np.pi * np.asarray(x_nm) / 360 + 19 + nodes) + 23)


def test_table_matches_the_ground_truth_weights_within_its_stated_bound(rng):
    wt = weight_transform()
    assert wt.interpolation_bound.max() <= 2e-10
    x = np.concatenate([[0.0, wt.step_nm * 3.5], rng.uniform(0, wt.x_max_nm, 200)])
    exact, rounding = _transform_in_long_double(x)
    err = np.abs(wt(x).T - exact)
    assert (err <= wt.interpolation_bound + _table_rounding(wt, x)[:, None] + rounding).all()
    # flat reflectance → white: Ŵ(0) = ∫ w = 1, a sum of N weights (γ_N ∫|w|)
    assert np.allclose(wt(np.zeros(1))[:, 0], 1.0, atol=_table_rounding(wt, 0.0))


def test_tail_bound_holds_and_decays_beyond_the_table():
    """The tail bound holds, and within 20×: the transform here is ≥ 2e-7, its panel rule's rounding
    (phases to 6e4 rad: ~1e-11) far below."""
    wt = weight_transform()
    for start in (2e3, 2e4, 2e5, 1e6, 3e6):
        x = np.linspace(start, 1.2 * start, 400)
        exact = np.abs(_transform_by_panels(x, 8 if start < 1e5 else 96)).max()
        assert exact <= wt.tail_bound(start) <= 20 * exact
    assert wt.tail_bound(1e6) <= 1.01e-4 * wt.tail_bound(1e4)  # 1/x² decay


def _series_at_phase(co, phase, terms=4000):
    """C0 + 2 Re Σ K q^{m−1} e^{imφ} for both polarizations (float64, summed to convergence)."""
    m = np.arange(1, terms + 1)
    z = np.exp(1j * m * phase)
    return [co.c0[p, 0] + 2 * np.real(np.sum(co.k[p, 0] * co.q[p, 0] ** (m - 1) * z)) for p in (0, 1)]


@pytest.mark.parametrize(
    "stack",
    [
        (1.0, 1.5, 2.2, 3.5, 0.6),  # metal base
        (1.0, 2.8, 1.2, 20.0, 0.05),  # near-resonant: |q| ≈ 0.99
        (1.0, 1.33, 1.0, 0.0, 0.9),  # soap film in air
    ],
)
def test_coefficients_give_the_textbook_airy_sum_at_50_digits(stack):
    """Within the float64 sum's rounding: term m (|K||q|^{m−1}) has its phase m·φ within 3u of it (φ,
    the product), e^{imφ} 8u, q^{m−1} and K, q's own rounding carried m times (4m u), and the sum of
    4,000 terms γ_4000; both polarizations, the real part doubled."""
    eta1, eta2, eta3, kappa3, cos_theta = stack
    co = series_coefficients(eta1, eta2, np.array([cos_theta]), np.array([1000.0]), eta3, kappa3)
    thickness = 1000.0 / (2 * eta2)
    m = np.arange(1, 4001)
    for lam in (400.0, 555.5, 801.0):
        phase = 2 * np.pi * co.x_nm[0] / lam
        got = _series_at_phase(co, phase)
        want = airy_reflectance_mp(eta1, eta2, eta3, kappa3, cos_theta, thickness, lam)
        rounding = [
            2
            * U_DOUBLE
            * np.sum(np.abs(co.k[p, 0]) * np.abs(co.q[p, 0]) ** (m - 1) * (3 * m * phase + 8 + 4 * m + m.size))
            + U_DOUBLE
            for p in (0, 1)
        ]
        assert (np.abs(np.array(got) - want) <= rounding).all()


def _random_texels(rng, n):
    return {
        "cos_theta": rng.uniform(0, 1, n),
        "opd_nm": rng.uniform(0, 4000, n),
        "eta3": rng.uniform(1, 3, n),
        "kappa3": rng.uniform(0, 5, n),
    }


def _truth(eta1, eta2, t):
    return reference_colour(FilmPoints.build(eta1=eta1, eta2=eta2, **t)).values


def test_series_matches_the_ground_truth_on_random_texels(rng):
    t = _random_texels(rng, 300)
    res = series_colour(FilmPoints.texels(eta1=1.0, eta2=1.5, **t))
    assert (res.terms >= 0).all()
    assert np.abs(res.values - _truth(1.0, 1.5, t)).max() <= 1e-8
    assert res.bound.max() <= 1e-8


def test_truncation_bound_is_honest_when_loose(rng):
    """With a loose tolerance the series stops early; its error stays within the recorded bound."""
    t = _random_texels(rng, 200)
    t["cos_theta"] = rng.uniform(0.02, 0.3, 200)  # high finesse: slow geometric decay
    res = series_colour(FilmPoints.texels(eta1=1.0, eta2=2.5, **t), tolerance=1e-4)
    ok = res.terms >= 0
    assert ok.sum() > 150
    err = np.abs(res.values[ok] - _truth(1.0, 2.5, t)[ok]).max(axis=1)
    assert (err <= res.bound[ok] + 1e-9).all()
    assert err.max() > 1e-7  # the tolerance did bite, so the comparison above is not vacuous


def _one(eta1, eta2, cos_theta, opd_nm, eta3, kappa3):
    t = {
        "cos_theta": np.array([cos_theta]),
        "opd_nm": np.array([opd_nm]),
        "eta3": np.array([eta3]),
        "kappa3": np.array([kappa3]),
    }
    return series_colour(FilmPoints.texels(eta1=eta1, eta2=eta2, **t)), _truth(eta1, eta2, t)


@pytest.mark.parametrize(
    "name, stack, terms",
    [
        ("zero thickness: closed form", (1.0, 1.5, 0.7, 0.0, 2.0, 3.0), 0),
        ("grazing over a matched base (q → 1, K = 0)", (1.0, 1.5, 0.0, 1000.0, 1.0, 0.0), 0),
        ("grazing over a metal", (1.0, 2.0, 0.0, 3000.0, 2.5, 4.0), 0),
        ("total reflection at the base", (1.5, 1.6, 0.3, 2000.0, 1.0, 0.0), None),
        ("thick film on a metal", (1.0, 1.5, 0.8, 20000.0, 2.0, 5.0), None),
    ],
)
def test_hard_cases_match_the_ground_truth(name, stack, terms):
    res, truth = _one(*stack)
    assert np.isfinite(res.values).all(), name
    assert np.abs(res.values - truth).max() <= 1e-8, name
    if terms is not None:
        assert res.terms[0] == terms, name


def test_total_reflection_at_the_base_has_no_fringes():
    co = series_coefficients(1.5, 1.6, np.array([0.3]), np.array([2000.0]), 1.0, 0.0)
    assert np.allclose(co.c0, 1.0, atol=1e-15) and np.abs(co.k).max() <= 1e-15


def test_texels_beyond_the_series_take_the_closed_form_and_evanescent_films_the_direct_path():
    evanescent, _ = _one(1.5, 1.2, 0.2, 1000.0, 1.5, 0.0)
    assert evanescent.terms[0] == -1 and evanescent.path[0] == 2 and np.isnan(evanescent.values).all()
    # |q| → 1 at a thick film: the table cannot carry the terms the bound needs; the poles can
    near_grazing, truth = _one(1.0, 2.0, 1e-4, 4000.0, 2.0, 20.0)
    assert near_grazing.terms[0] == -1 and near_grazing.path[0] == 1
    assert np.abs(near_grazing.values - truth).max() <= 1e-10 and near_grazing.bound[0] <= 1e-9
    # more terms than the budget: the series is not picked
    film = FilmPoints.texels(eta1=1.0, eta2=1.5, cos_theta=[0.5], opd_nm=[3000.0], eta3=2.0, kappa3=4.0)
    fine = series_colour(film)
    costly = series_colour(film, budget=fine.terms[0] - 1)
    assert fine.terms[0] > 1 and costly.terms[0] == -1 and costly.path[0] == 1
    assert np.abs(costly.values - fine.values).max() <= 1e-9


# --- the bake kernel's series (kernels/airy.cl: bake_rows_series, plan_rows) ---


def _random_grid(rng, **kw):
    from lutbake.grid.spec import Axis, BakeSpec

    lo = [rng.uniform(0, 0.3), rng.uniform(0, 500), rng.uniform(1, 1.5), rng.uniform(0, 1)]
    hi = [rng.uniform(0.7, 1.0), rng.uniform(2000, 6000), rng.uniform(2, 3.5), rng.uniform(2, 8)]
    names, spacing = ["cos_theta", "opd_nm", "eta3", "kappa3"], ["sqrt", "uniform", "uniform", "sqrt"]
    axes = tuple(Axis(n, a, b, c, s) for n, a, b, c, s in zip(names, lo, hi, (32, 64, 8, 8), spacing))
    # 8 samples per cycle: the direct rule to ~1e-9, so it can referee the series at 1e-7
    return BakeSpec(eta2=rng.uniform(1.2, 2.5), axes=axes, samples_per_cycle=8.0, **kw)


@pytest.fixture(scope="module")
def grid_spec():
    return _random_grid(np.random.default_rng(12))


@pytest.fixture(scope="module")
def series_grid(grid_spec, kernel_device):
    from lutbake.lut.bake import bake_array

    return bake_array(grid_spec, "opencl", device=kernel_device)


def test_kernel_series_equals_the_direct_path_on_every_texel(grid_spec, series_grid, kernel_device):
    from lutbake.lut.bake import bake_array

    direct = bake_array(grid_spec, "opencl", "direct", kernel_device)
    assert np.max(np.abs(series_grid - direct)) <= 1e-7


def test_kernel_rule_is_the_numpy_rule(grid_spec, kernel_device):
    from lutbake.integrate.opencl import OpenCLBackend

    stats = OpenCLBackend("float64", device=kernel_device).series_plan(grid_spec)
    params = [np.ravel(p) for p in grid_spec.cell_params(0, grid_spec.image_size[1])]
    paths = np.bincount(series_colour(grid_spec.texel_stacks(params)).path, minlength=3)
    assert sum(stats.texels) == grid_spec.cells
    assert np.abs(np.array(stats.texels) - paths).max() <= grid_spec.cells // 10000
    assert stats.series_texels > 0.9 * grid_spec.cells and 1e-9 < stats.bounds[0] <= 1e-7


def test_series_inputs_copied_to_the_device_chunk_by_chunk_are_the_whole(
    grid_spec, series_grid, kernel_device, monkeypatch
):
    """The series constants go to the device a chunk of columns (and of (cos θ, D) pairs) at a time, each at
    its offset (the host never holds them whole): with 37-row chunks, 56 of each, the bake is the same."""
    import lutbake.integrate.series
    from lutbake.lut.bake import bake_array

    monkeypatch.setattr(lutbake.integrate.series, "CHUNK", 37)
    assert np.array_equal(bake_array(grid_spec, "opencl", device=kernel_device), series_grid)


def test_kernel_series_float32_within_2e5_of_float64(grid_spec, series_grid, kernel_device):
    from dataclasses import replace

    from lutbake.lut.bake import bake_array

    f32 = bake_array(replace(grid_spec, compute="float32"), "opencl", device=kernel_device)
    assert np.max(np.abs(f32 - series_grid)) <= 2e-5


def test_kernel_falls_back_to_the_direct_path_for_evanescent_films():
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.integrate.opencl import OpenCLBackend
    from lutbake.lut.bake import bake_array

    axes = (
        Axis("cos_theta", 0.0, 1.0, 16),
        Axis("opd_nm", 0.0, 3000.0, 16),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 4.0, 4),
    )
    spec = BakeSpec(eta2=1.2, eta1=1.5, axes=axes, samples_per_cycle=8.0)
    stats = OpenCLBackend("float64").series_plan(spec)
    # cos θ1 < √(1 − (1.2/1.5)²) = 0.6: evanescent film, 9 of 16 cos θ nodes
    assert stats.direct_texels >= 9 * 16 * 16
    assert np.max(np.abs(bake_array(spec, "opencl") - bake_array(spec, "opencl", "direct"))) <= 1e-7


def test_kernel_series_for_another_observer_and_space():
    from lutbake.grid.spec import Axis, BakeSpec
    from lutbake.lut.bake import bake_array

    axes = (
        Axis("cos_theta", 0.0, 1.0, 8),
        Axis("opd_nm", 0.0, 4000.0, 16),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 5.0, 4),
    )
    spec = BakeSpec(eta2=1.7, axes=axes, observer="cie1964", space="acescg", samples_per_cycle=8.0)
    assert np.max(np.abs(bake_array(spec, "opencl") - bake_array(spec, "opencl", "direct"))) <= 1e-7


def test_table_cache_lives_in_the_user_cache_and_survives_corruption(tmp_path, cache_folder):
    """The Ŵ table persists in the user cache (not the shared temp folder); an unreadable or
    truncated cache file is rebuilt, giving the same table as a fresh build."""
    cache_folder(tmp_path / "cache")
    args = {"space": "p3", "step_nm": 50.0, "x_max_nm": 3000.0}
    weight_transform.cache_clear()
    fresh = weight_transform(**args)
    (cached,) = (tmp_path / "cache").glob("fourier-*")
    good = cached.read_bytes()
    for damage in (b"not a numpy file", good[: len(good) // 2]):
        cached.write_bytes(damage)
        weight_transform.cache_clear()
        rebuilt = weight_transform(**args)
        np.testing.assert_array_equal(rebuilt.coefficients, fresh.coefficients)
        with np.load(cached) as stored, np.load(io.BytesIO(good)) as first:
            np.testing.assert_array_equal(stored["f"], first["f"])  # rewritten whole
    weight_transform.cache_clear()
