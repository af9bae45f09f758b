"""The Fourier-series integrator (lutbake.fourier) against independent references."""

import numpy as np
import pytest

from airy_mp import airy_reflectance_mp
from lutbake.fourier import series_coefficients, series_colour, weight_transform
from lutbake.points import FilmPoints
from lutbake.reference import reference_colour
from lutbake.spectral import panel_rule

NO_COST_CAP = 1 << 20   # direct-rule node count that never vetoes the series


def _transform_by_panels(x_nm, nodes_per_nm=64):
    """Ŵ_c(x) from the ground truth's own Gauss–Legendre panel rule, far finer than the table's."""
    rule = panel_rule(nodes_per_nm)
    return np.exp(2j * np.pi * np.outer(x_nm, 1.0 / rule.wavelength_nm)) @ rule.weights.T


def test_table_matches_the_ground_truth_weights_within_its_stated_bound(rng):
    wt = weight_transform()
    assert wt.interpolation_bound.max() <= 2e-10
    x = np.concatenate([[0.0, wt.step_nm * 3.5], rng.uniform(0, wt.x_max_nm, 200)])
    err = np.abs(wt(x).T - _transform_by_panels(x))
    assert err.max() <= wt.interpolation_bound.max() + 1e-12
    assert np.allclose(wt(np.zeros(1))[:, 0], 1.0, atol=1e-12)   # flat reflectance → white


def test_tail_bound_holds_and_decays_beyond_the_table():
    wt = weight_transform()
    for start in (2e3, 2e4, 2e5, 1e6, 3e6):
        x = np.linspace(start, 1.2 * start, 400)
        exact = np.abs(_transform_by_panels(x, 8 if start < 1e5 else 96)).max()
        assert exact <= wt.tail_bound(start) <= 20 * exact + 1e-12
    assert wt.tail_bound(1e6) <= 1.01e-4 * wt.tail_bound(1e4)   # 1/x² decay


def _series_at_phase(co, phase, terms=4000):
    """C0 + 2 Re Σ K q^{m−1} e^{imφ} for both polarizations (float64, summed to convergence)."""
    m = np.arange(1, terms + 1)
    z = np.exp(1j * m * phase)
    return [co.c0[p, 0] + 2 * np.real(np.sum(co.k[p, 0] * co.q[p, 0] ** (m - 1) * z)) for p in (0, 1)]


@pytest.mark.parametrize("stack", [
    (1.0, 1.5, 2.2, 3.5, 0.6),     # metal base
    (1.0, 2.8, 1.2, 20.0, 0.05),   # near-resonant: |q| ≈ 0.99
    (1.0, 1.33, 1.0, 0.0, 0.9),    # soap film in air
])
def test_coefficients_give_the_textbook_airy_sum_at_50_digits(stack):
    eta1, eta2, eta3, kappa3, cos_theta = stack
    co = series_coefficients(eta1, eta2, np.array([cos_theta]), np.array([1000.0]), eta3, kappa3)
    thickness = 1000.0 / (2 * eta2)
    for lam in (400.0, 555.5, 801.0):
        phase = 2 * np.pi * co.x_nm[0] / lam
        got = _series_at_phase(co, phase)
        want = airy_reflectance_mp(eta1, eta2, eta3, kappa3, cos_theta, thickness, lam)
        assert np.allclose(got, want, rtol=0, atol=1e-12)


def _random_texels(rng, n):
    return dict(cos_theta=rng.uniform(0, 1, n), opd_nm=rng.uniform(0, 4000, n),
                eta3=rng.uniform(1, 3, n), kappa3=rng.uniform(0, 5, n))


def _truth(eta1, eta2, t):
    return reference_colour(FilmPoints.build(eta1=eta1, eta2=eta2, **t)).values


def test_series_matches_the_ground_truth_on_random_texels(rng):
    t = _random_texels(rng, 300)
    res = series_colour(1.0, 1.5, *t.values(), NO_COST_CAP)
    assert (res.terms >= 0).all()
    assert np.abs(res.values - _truth(1.0, 1.5, t)).max() <= 1e-8
    assert res.bound.max() <= 1e-8


def test_truncation_bound_is_honest_when_loose(rng):
    """With a loose tolerance the series stops early; its error stays within the recorded bound."""
    t = _random_texels(rng, 200)
    t["cos_theta"] = rng.uniform(0.02, 0.3, 200)   # high finesse: slow geometric decay
    res = series_colour(1.0, 2.5, *t.values(), NO_COST_CAP, tolerance=1e-4)
    ok = res.terms >= 0
    assert ok.sum() > 150
    err = np.abs(res.values[ok] - _truth(1.0, 2.5, t)[ok]).max(axis=1)
    assert (err <= res.bound[ok] + 1e-9).all()
    assert err.max() > 1e-7   # the tolerance did bite, so the comparison above is not vacuous


def _one(eta1, eta2, cos_theta, opd_nm, eta3, kappa3):
    t = dict(cos_theta=np.array([cos_theta]), opd_nm=np.array([opd_nm]), eta3=np.array([eta3]),
             kappa3=np.array([kappa3]))
    return series_colour(eta1, eta2, *t.values(), NO_COST_CAP), _truth(eta1, eta2, t)


@pytest.mark.parametrize("name, stack, terms", [
    ("zero thickness: closed form", (1.0, 1.5, 0.7, 0.0, 2.0, 3.0), 0),
    ("grazing over a matched base (q → 1, K = 0)", (1.0, 1.5, 0.0, 1000.0, 1.0, 0.0), 0),
    ("grazing over a metal", (1.0, 2.0, 0.0, 3000.0, 2.5, 4.0), 0),
    ("total reflection at the base", (1.5, 1.6, 0.3, 2000.0, 1.0, 0.0), None),
    ("thick film on a metal", (1.0, 1.5, 0.8, 20000.0, 2.0, 5.0), None),
])
def test_hard_cases_match_the_ground_truth(name, stack, terms):
    res, truth = _one(*stack)
    assert np.isfinite(res.values).all(), name
    assert np.abs(res.values - truth).max() <= 1e-8, name
    if terms is not None:
        assert res.terms[0] == terms, name


def test_total_reflection_at_the_base_has_no_fringes():
    co = series_coefficients(1.5, 1.6, np.array([0.3]), np.array([2000.0]), 1.0, 0.0)
    assert np.allclose(co.c0, 1.0, atol=1e-15) and np.abs(co.k).max() <= 1e-15


def test_out_of_scope_texels_take_the_direct_path():
    evanescent, _ = _one(1.5, 1.2, 0.2, 1000.0, 1.5, 0.0)
    assert evanescent.terms[0] == -1 and np.isnan(evanescent.values).all()
    # |q| → 1 at a thick film: the table cannot carry the terms the bound needs
    near_grazing = series_colour(1.0, 2.0, np.array([1e-4]), np.array([4000.0]), 2.0, 20.0, NO_COST_CAP)
    assert near_grazing.terms[0] == -1
    # cheaper by direct quadrature: the series is not picked
    costly = series_colour(1.0, 1.5, np.array([0.5]), np.array([3000.0]), 2.0, 4.0, np.array([4]))
    assert costly.terms[0] == -1
