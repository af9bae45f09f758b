"""The poles' closed form (lutbake.poles) against independent references: quadrature of the Cauchy
transform, brute-force Gauss–Legendre of the whole integral, the converged series, the ground truth, and
the kernel's direct quadrature."""

import numpy as np
import pytest

from lutbake.fourier import series_colour, weight_transform
from lutbake.plan import Axis, BakeSpec
from lutbake.points import FilmPoints
from lutbake.poles import (DEEP_LIMIT_NM, RE_MAX_NM, RE_MIN_NM, SHALLOW_NM, cauchy_table, chebyshev_rule,
                           closed_form)
from lutbake.reference import reference_colour
from lutbake.spectral import panel_rule


def _gauss_legendre(nodes_per_nm):
    rule = panel_rule(nodes_per_nm)
    return rule.wavelength_nm, rule.weights


def test_cauchy_table_is_the_quadrature_of_the_weights_within_its_bound(rng):
    """Γ_c(P) = ∫ w_c/(λ − P) dλ by 64 Gauss–Legendre nodes per nm (converged to rounding for
    Im P ≥ 0.2 nm) at points in both regimes, on knots, between them and past the band's ends."""
    table = cauchy_table()
    lam, w = _gauss_legendre(64)
    re = np.concatenate([rng.uniform(RE_MIN_NM, RE_MAX_NM, 150), [360.0, 830.0, 500.0, 359.5, 830.5, 200.2]])
    im = np.concatenate([10 ** rng.uniform(np.log10(0.2), np.log10(DEEP_LIMIT_NM) - 0.01, 150), [0.2] * 6])
    P = re + 1j * im
    quadrature = (w[:, None, :] / (lam[None, None, :] - P[None, :, None])).sum(axis=2)
    assert table.bound.max() <= 1e-13
    assert np.abs(table(P) - quadrature).max() <= table.bound.max() + 1e-13
    assert (im < SHALLOW_NM).sum() > 20 and (im >= SHALLOW_NM).sum() > 20   # both regimes exercised


def test_cauchy_table_near_the_real_axis_is_the_exact_knot_sum(rng):
    """Within 1e-6 nm of a knot the table's near knots are summed exactly: the table equals the
    closed-form knot sum of every panel (no quadrature can resolve this close)."""
    table = cauchy_table()
    P = rng.integers(362, 828, 50) + rng.uniform(-1e-6, 1e-6, 50) + 1j * 10 ** rng.uniform(-12, -6, 50)
    knots = np.arange(360.0, 831.0)
    exact = table.constant[:, None] + ((table.knot_a[:, None, :] + table.knot_b[:, None, :] * P[None, :, None])
                                       * np.log(knots[None, None, :] - P[None, :, None])).sum(axis=2)
    assert np.abs(table(P) - exact).max() <= 1e-13


def test_chebyshev_weights_integrate_every_polynomial_of_their_degree(rng):
    rule = chebyshev_rule()
    lam, w = _gauss_legendre(32)
    for degree in (0, 7, 40):
        coef = rng.normal(size=degree + 1)
        poly = np.polynomial.chebyshev.Chebyshev(coef, domain=[360.0, 830.0])
        assert np.allclose(rule.weights @ poly(rule.wavelength_nm), w @ poly(lam), rtol=0, atol=1e-13)
    lam, w = _gauss_legendre(512)   # |w_c| kinks where w_c changes sign: converges slowly, hence 512
    assert np.allclose(rule.mass, np.abs(w).sum(axis=1), rtol=1e-8)


def _stiff_cases(rng, n):
    """(K, q, X): films ringing hard (1 − |q| down to 3e-4), thin to 6 µm, every phase of q."""
    X = rng.choice([0.07, 5.0, 50.0, 300.0, 1000.0, 3000.0, 6000.0], n) * rng.uniform(0.5, 1.0, n)
    q = (1 - 10 ** rng.uniform(-3.5, -0.5, n)) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    return rng.normal(size=n) + 1j * rng.normal(size=n), q, X


def _brute_force(K, q, X, nodes_per_nm=2048):
    """∫ w_c K z/(1 − q z) dλ by Gauss–Legendre on every 1 nm panel. The sharpest peaks here are
    0.003 nm wide: 2,048 nodes per nm converge there (512 leave 1e-8)."""
    lam, w = _gauss_legendre(nodes_per_nm)
    out = np.empty((K.size, 3), complex)
    for i in range(K.size):
        z = np.exp(2j * np.pi * X[i] / lam)
        out[i] = w @ (K[i] * z / (1 - q[i] * z))
    return out


def test_closed_form_equals_brute_force_quadrature_within_its_bound(rng):
    K, q, X = _stiff_cases(rng, 24)
    result = closed_form(K, q, X)
    assert result.ok.all() and (result.near_poles > 0).sum() >= 12
    error = np.abs(result.integral - _brute_force(K, q, X)).max(axis=1)
    assert (error <= result.bound + 5e-13).all()    # the brute force's own rounding: ~1e-13
    assert error.max() <= 1e-11 and (result.bound <= 1e-9 * np.abs(K)).all()


def test_closed_form_equals_the_series_where_both_converge(rng):
    """|q| ≤ 0.9: the series converges inside the table; it carries the table's interpolation error
    (measured ≤ 9e-13 per term, tests/test_fourier.py) through its terms."""
    n = 30
    X = rng.uniform(1.0, 2000.0, n)
    q = rng.uniform(0.3, 0.9, n) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    K = rng.normal(size=n) + 1j * rng.normal(size=n)
    wt = weight_transform()
    series = np.zeros((n, 3), complex)
    for m in range(1, 400):
        series += (K * q ** (m - 1))[:, None] * wt(np.minimum(m * X, wt.x_max_nm)).T * (m * X <= wt.x_max_nm)[:, None]
    assert np.abs(closed_form(K, q, X).integral - series).max() <= 1e-10


def test_texels_the_series_cannot_take_match_the_ground_truth():
    """The default metal LUTs' stiffest corner (η3 0.02, κ3 1.5–9, grazing): before the closed form these
    took the direct quadrature at up to 16,384 nodes (measured 5e-7 off); now they are exact."""
    cos_theta = np.repeat([0.00104, 0.0042, 0.0166], 6)
    opd = np.tile([50.0, 700.0, 3000.0], 6)
    kappa3 = np.tile(np.repeat([1.5, 9.0], 3), 3)
    stacks = FilmPoints.texels(eta1=1.0, eta2=2.0, cos_theta=cos_theta, opd_nm=opd, eta3=0.02, kappa3=kappa3)
    result = series_colour(stacks)
    assert (result.path == 1).sum() >= 12
    truth = reference_colour(FilmPoints.build(eta1=1.0, eta2=2.0, cos_theta=cos_theta, opd_nm=opd, eta3=0.02,
                                              kappa3=kappa3)).values
    assert np.abs(result.values - truth).max() <= 1e-10
    assert result.bound[result.path == 1].max() <= 1e-9


# --- the kernel's closed form (kernels/poles.cl: bake_texels_closed, plan_rows) ---

@pytest.fixture(scope="module")
def stiff_spec():
    """Metals near grazing incidence, films to 6 µm: a fifth of the texels beyond the series."""
    axes = (Axis("cos_theta", 0.0, 0.1, 8, "sqrt"), Axis("opd_nm", 0.0, 6000.0, 16, "sqrt"),
            Axis("eta3", 0.02, 4.0, 4, "sqrt"), Axis("kappa3", 1.5, 20.0, 4, "sqrt"))
    return BakeSpec(eta2=2.0, axes=axes, samples_per_cycle=8.0)


def test_kernel_closed_form_is_the_numpy_closed_form_and_the_plan_counts_it(stiff_spec, kernel_device):
    from lutbake.bake import bake_array
    from lutbake.integrate import OpenCLBackend

    params = [np.ravel(p) for p in stiff_spec.cell_params(0, stiff_spec.image_size[1])]
    reference = series_colour(stiff_spec.texel_stacks(params))
    stats = OpenCLBackend("float64", device=kernel_device).series_plan(stiff_spec)
    assert stats.texels == np.bincount(reference.path, minlength=3).tolist()
    assert stats.closed_form_texels > stiff_spec.cells // 8 and stats.direct_texels == 0
    assert 0 < stats.bounds[1] <= 1e-9
    kernel = bake_array(stiff_spec, "opencl", device=kernel_device).reshape(-1, 3)
    assert np.abs(kernel - reference.values).max() <= 1e-12


def test_kernel_closed_form_equals_the_direct_quadrature(stiff_spec, kernel_device):
    """The direct path (8 samples per cycle: ~1e-9 where its rule does not hit the node cap) referees
    the closed form on every texel it resolves."""
    from lutbake.bake import bake_array

    closed = bake_array(stiff_spec, "opencl", device=kernel_device).reshape(-1, 3)
    direct = bake_array(stiff_spec, "opencl", "direct", kernel_device).reshape(-1, 3)
    params = [np.ravel(p) for p in stiff_spec.cell_params(0, stiff_spec.image_size[1])]
    resolved = stiff_spec.truncation_estimate(*params) == 0
    beyond = series_colour(stiff_spec.texel_stacks(params)).path == 1
    assert (beyond & resolved).sum() > 100
    assert np.abs(closed - direct)[resolved].max() <= 1e-7
