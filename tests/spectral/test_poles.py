"""The poles' closed form (lutbake.spectral.poles) against independent references: quadrature of the Cauchy
transform, a converged Gauss–Legendre quadrature of the whole integral in long double, the converged
series, the ground truth, and the kernel's direct quadrature."""

from dataclasses import replace

import numpy as np
import pytest
from long_quadrature import LONG, U_DOUBLE, U_LONG, BandRule, gauss_legendre

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.physics.points import FilmPoints
from lutbake.spectral.fourier import series_colour, weight_transform
from lutbake.spectral.poles import (
    DEEP_LIMIT_NM,
    RE_MAX_NM,
    RE_MIN_NM,
    SHALLOW_NM,
    cauchy_table,
    chebyshev_rule,
    closed_form,
)
from lutbake.spectral.reference import DEFAULT_TOLERANCE, reference_colour
from lutbake.spectral.rules import panel_rule

KNOTS_NM = np.arange(360.0, 831.0)
PROBABLE = 8.0  # λ of the probabilistic bound below: 2N e^{−λ²/2} ≤ 3e-10 for N ≤ 10^4


def _table_rounding(table, P):
    """A bound (3, n) on the Cauchy table's float64 rounding at P: the table stands for the knot sum
    Γ_c = G_c + Σ_k (a_ck + b_ck P) log(k − P) over K = 471 knots, whose terms' magnitudes add to S_c(P)
    (up to ~14 here, against |Γ_c| ≤ 0.07: they cancel). Its Taylor coefficients are float64 sums over
    the knots: a sum of K independently rounded terms errs by ≤ λ√K u Σ|terms| with probability
    ≥ 1 − 2K e^{−λ²/2} (Higham and Mary, SIAM J. Sci. Comput. 41, 2019; λ = PROBABLE), and the
    coefficients' terms, times (P − centre)^m, add to < 2 S (the far knots are ≥ 3.5 cells away, the
    centre ≤ 1.12 from P); Horner's rule of degree d ≤ 22 adds 2d u S, the 8 near knots (log within
    4 ulp, a + bP, the product, the sum) 13u S. So ≤ (2λ√K + 44 + 13) u S_c(P)."""
    S = np.abs(table.constant)[:, None] + (
        np.abs(table.knot_a[:, None, :] + table.knot_b[:, None, :] * P[None, :, None])
        * np.abs(np.log(KNOTS_NM[None, None, :] - P[None, :, None]))
    ).sum(axis=2)
    return (2 * PROBABLE * np.sqrt(KNOTS_NM.size) + 44 + 13) * U_DOUBLE * S


def _unit(wavelength_nm):
    """The band mapped onto [−1, 1]: Chebyshev's variable."""
    return (wavelength_nm - 595) / 235


def _cauchy_quadrature(P):
    """Γ_c(P) by BandRule graded toward P, and its rounding bound: 1/(λ − P) moves by the node's 2uλ
    over |λ − P|, rounds in the subtraction (u) and the division (8u: Higham, Accuracy and Stability,
    §3.6, √2γ_4)."""
    rule = BandRule([P])
    distance = rule.nm - P
    f = 1 / distance
    return rule.integral(f, U_LONG * np.abs(f) * (2 * rule.nm / np.abs(distance) + 9))


def test_cauchy_table_is_the_quadrature_of_the_weights_within_its_bound(rng):
    """Γ_c(P) = ∫ w_c/(λ − P) dλ by _cauchy_quadrature at points in both regimes, on knots, between them
    and past the band's ends: within the table's a-priori bound, its rounding (_table_rounding) and the
    quadrature's."""
    table = cauchy_table()
    re = np.concatenate([rng.uniform(RE_MIN_NM, RE_MAX_NM, 150), [360.0, 830.0, 500.0, 359.5, 830.5, 200.2]])
    im = np.concatenate([10 ** rng.uniform(np.log10(0.2), np.log10(DEEP_LIMIT_NM) - 0.01, 150), [0.2] * 6])
    P = re + 1j * im
    quadrature, rounding = (np.array(v) for v in zip(*map(_cauchy_quadrature, P)))
    assert table.bound.max() <= 1e-13
    assert (np.abs(table(P) - quadrature.T) <= table.bound[:, None] + _table_rounding(table, P) + rounding.T).all()
    assert (im < SHALLOW_NM).sum() > 20 and (im >= SHALLOW_NM).sum() > 20  # both regimes exercised


def test_cauchy_table_near_the_real_axis_is_the_exact_knot_sum(rng):
    """Within 1e-6 nm of a knot the table's near knots are summed exactly: the table equals the
    closed-form knot sum of every panel (no quadrature can resolve this close), summed in long double
    (its terms within 13u, the sum γ_K), within the table's bound and rounding (_table_rounding)."""
    table = cauchy_table()
    P = rng.integers(362, 828, 50) + rng.uniform(-1e-6, 1e-6, 50) + 1j * 10 ** rng.uniform(-12, -6, 50)
    P_long = P.astype(np.clongdouble)
    terms = (table.knot_a[:, None, :] + table.knot_b[:, None, :] * P_long[None, :, None]) * np.log(
        KNOTS_NM[None, None, :] - P_long[None, :, None]
    )
    exact = (table.constant[:, None] + terms.sum(axis=2)).astype(complex)
    exact_rounding = ((13 + 2 * KNOTS_NM.size) * U_LONG * np.abs(terms).sum(axis=2)).astype(float) + U_DOUBLE * np.abs(
        exact
    )
    assert (np.abs(table(P) - exact) <= table.bound[:, None] + _table_rounding(table, P) + exact_rounding).all()


def test_chebyshev_weights_integrate_every_polynomial_of_their_degree(rng):
    """Σ_i W_ci p(λ_i) (the rule's float64 weights, p summed in long double) against ∫ w_c p by BandRule
    (exact for the degree here), for p = Σ_k c_k T_k of degree 0, 7 and 40: Σ_i W_ci p(λ_i) = Σ_k c_k μ_ck,
    the rule's moments, each a float64 sum of N = 10,340 terms (leggauss(22) on every 1 nm panel) of
    magnitudes adding to ≤ ∫|w_c|: within Σ|c_k|·∫|w_c|·(λ√N u + ε_GL) (probabilistic, as in
    _table_rounding; ε_GL the largest relative error of numpy's 22 Gauss–Legendre weights, against
    mpmath's), plus the 41-point transform to weights, within Σ_i|p(λ_i)|·(2/40)·λ√41 u·Σ_k|μ_ck|."""
    rule, band = chebyshev_rule(), BandRule()
    eps_gl = float(np.abs(np.polynomial.legendre.leggauss(22)[1] / gauss_legendre(22)[1] - 1).max())
    moments = np.abs(
        (band.weights[:, None, :] * np.polynomial.chebyshev.chebvander(_unit(band.nm), 40).T).sum(axis=2)
    ).astype(float)  # |μ_ck| (3, 41)
    for degree in (0, 7, 40):
        coef = rng.normal(size=degree + 1)
        clenshaw = 2 * (degree + 1) ** 2 * U_LONG * np.abs(coef).sum()  # p's evaluation in long double
        values = np.polynomial.chebyshev.chebval(_unit(rule.wavelength_nm.astype(LONG)), coef)
        got = (rule.weights.astype(LONG) * values).sum(axis=1).astype(float)
        exact, exact_rounding = band.integral(
            np.polynomial.chebyshev.chebval(_unit(band.nm), coef), np.full(band.nm.size, clenshaw)
        )
        construction = np.abs(coef).sum() * rule.mass * (PROBABLE * np.sqrt(470 * 22) * U_DOUBLE + eps_gl) + np.abs(
            values
        ).astype(float).sum() * 2 / 40 * PROBABLE * np.sqrt(41) * U_DOUBLE * moments.sum(axis=1)
        evaluation = np.abs(rule.weights).sum(axis=1) * clenshaw + U_DOUBLE * np.abs(got)
        assert (np.abs(got - exact) <= construction + evaluation + exact_rounding).all()
    w = panel_rule(512).weights  # |w_c| kinks where w_c changes sign: converges slowly, hence 512
    assert np.allclose(rule.mass, np.abs(w).sum(axis=1), rtol=1e-8)


def _stiff_cases(rng, n):
    """(K, q, X): films ringing hard (1 − |q| down to 3e-4), thin to 6 µm, every phase of q."""
    X = rng.choice([0.07, 5.0, 50.0, 300.0, 1000.0, 3000.0, 6000.0], n) * rng.uniform(0.5, 1.0, n)
    q = (1 - 10 ** rng.uniform(-3.5, -0.5, n)) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    return rng.normal(size=n) + 1j * rng.normal(size=n), q, X


def _film_poles_nm(q, X):
    """The complex λ (Im > 0) where q e^{i2πX/λ} = 1, i.e. 2πX/λ = 2πk − arg q + i log|q|, for the k
    whose real part falls within 2 nm of the band."""
    arg, log_abs = np.angle(q), np.log(np.abs(q))
    k = np.arange(
        np.ceil((2 * np.pi * X / 832.0 + arg) / (2 * np.pi)), np.floor((2 * np.pi * X / 358.0 + arg) / (2 * np.pi)) + 1
    )
    return 2 * np.pi * X / (2 * np.pi * k - arg + 1j * log_abs)


def _reference_quadrature(K, q, X):
    """∫ w_c K z/(1 − q z) dλ (n, 3) by BandRule graded toward the integrand's poles, in long double, and
    a first-order bound on its rounding (n, 3).

    The integrand peaks at |K|/(1 − |q|), and an error δ in the node or the phase φ = 2πX/λ moves it by
    δ/|1 − q z|: in double that rounding alone reaches 1e-12 here. Per node (u = U_LONG; the weights'
    rounding and the sum's: BandRule): φ: 2π, ·X and /λ rounded, 3u, with the node's move 2uλ:
    |δφ| ≤ 5uφ;  z = e^{iφ}: cos, sin within 4 ulp (8u), |δz| ≤ 8u; z enters f as δz/(z(1 − q z)):
    (5φ + 8)u/|1 − q z|;  q z: √5 u|q| (complex product), over |1 − q z|;  1 − q z: u;  K z: √5 u;
    the division: 8u (Higham, Accuracy and Stability, §3.6: √2γ_4 for the textbook formula); 12u for
    the last three."""
    integral, rounding = np.empty((K.size, 3), complex), np.empty((K.size, 3))
    for i in range(K.size):
        rule = BandRule(_film_poles_nm(q[i], X[i]))
        phase = rule.two_pi * LONG(X[i]) / rule.nm
        z = np.exp(1j * phase)
        one_minus_qz = 1 - q[i] * z
        f = K[i] * z / one_minus_qz
        f_rounding = U_LONG * np.abs(f) * ((5 * phase + 8 + np.sqrt(5) * abs(q[i])) / np.abs(one_minus_qz) + 12)
        integral[i], rounding[i] = rule.integral(f, f_rounding)
    return integral, rounding


def test_closed_form_equals_a_converged_quadrature_within_both_bounds(rng):
    """The closed form against _reference_quadrature at 24 stiff cases, per channel: within the closed
    form's a-priori bound plus the quadrature's rounding bound (the latter ≤ 0.44 of the former over 200
    seeds of these cases, so an error of 1.5× the bound fails). The closed form's bound leaves out its own
    float64 rounding (lutbake/spectral/poles.py states none): beyond the quadrature's bound, its error measured
    ≤ 0.17 of the bound over those 200 seeds (AMD Zen 4, numpy 2.4)."""
    K, q, X = _stiff_cases(rng, 24)
    result = closed_form(K, q, X)
    assert result.ok.all() and (result.near_poles > 0).sum() >= 6  # a quarter at least: poles near the band
    reference, rounding = _reference_quadrature(K, q, X)
    assert (np.abs(result.integral - reference) <= result.bound[:, None] + rounding).all()
    assert (result.bound <= 1e-9 * np.abs(K)).all()  # within the series' tolerance: the closed form is used


def test_closed_form_equals_the_series_where_both_converge(rng):
    """|q| ≤ 0.9: the series, summed from the weight table to 400 terms, converges inside the table. It
    differs from the integral by the table's interpolation bound per term (Σ|K q^{m−1}| of it), the terms
    past the table (m X > its end: each within the tail bound there) and past the 400th (|q|^399/(1 − |q|)
    of ∫|w|), and its float64 sum (≤ 400u Σ|terms|); the closed form by its bound."""
    n = 30
    X = rng.uniform(1.0, 2000.0, n)
    q = rng.uniform(0.3, 0.9, n) * np.exp(1j * rng.uniform(-np.pi, np.pi, n))
    K = rng.normal(size=n) + 1j * rng.normal(size=n)
    wt = weight_transform()
    series, size, past_table = np.zeros((n, 3), complex), np.zeros((n, 3)), np.zeros(n)
    for m in range(1, 400):
        inside = m * X <= wt.x_max_nm
        term = (K * q ** (m - 1))[:, None] * wt(np.minimum(m * X, wt.x_max_nm)).T * inside[:, None]
        series, size = series + term, size + np.abs(term)
        past_table += np.abs(K * q ** (m - 1)) * ~inside
    interpolation = np.abs(K) / (1 - np.abs(q)) * wt.interpolation_bound.max()
    past_400 = np.abs(K) * np.abs(q) ** 399 / (1 - np.abs(q)) * wt.mass.max()
    allowed = (closed_form(K, q, X).bound + interpolation + past_table * wt.tail_bound(wt.x_max_nm) + past_400)[:, None]
    assert (np.abs(closed_form(K, q, X).integral - series) <= allowed + 400 * U_DOUBLE * size).all()


def test_texels_the_series_cannot_take_match_the_ground_truth():
    """The default metal LUTs' stiffest corner (η3 0.02, κ3 1.5–9, grazing): before the closed form these
    took the direct quadrature at up to 16,384 nodes (measured 5e-7 off); now they are exact: within
    their bound (both polarizations) plus the truth's, refined until two refinements agree to 1e-9
    (reference.DEFAULT_TOLERANCE)."""
    cos_theta = np.repeat([0.00104, 0.0042, 0.0166], 6)
    opd = np.tile([50.0, 700.0, 3000.0], 6)
    kappa3 = np.tile(np.repeat([1.5, 9.0], 3), 3)
    stacks = FilmPoints.texels(eta1=1.0, eta2=2.0, cos_theta=cos_theta, opd_nm=opd, eta3=0.02, kappa3=kappa3)
    result = series_colour(stacks)
    assert (result.path == 1).sum() >= 12
    truth = reference_colour(
        FilmPoints.build(eta1=1.0, eta2=2.0, cos_theta=cos_theta, opd_nm=opd, eta3=0.02, kappa3=kappa3)
    ).values
    assert (np.abs(result.values - truth) <= result.bound[:, None] + DEFAULT_TOLERANCE).all()
    assert result.bound[result.path == 1].max() <= 1e-9


# --- the kernel's closed form (kernels/poles.cl: bake_texels_closed, plan_rows) ---


@pytest.fixture(scope="module")
def stiff_spec():
    """Metals near grazing incidence, films to 6 µm: a fifth of the texels beyond the series."""
    axes = (
        Axis("cos_theta", 0.0, 0.1, 8, "sqrt"),
        Axis("opd_nm", 0.0, 6000.0, 16, "sqrt"),
        Axis("eta3", 0.02, 4.0, 4, "sqrt"),
        Axis("kappa3", 1.5, 20.0, 4, "sqrt"),
    )
    return BakeSpec(eta2=2.0, axes=axes, samples_per_cycle=8.0)


def test_kernel_closed_form_is_the_numpy_closed_form_and_the_plan_counts_it(stiff_spec, kernel_device):
    from lutbake.integrate.opencl import OpenCLBackend
    from lutbake.lut.bake import bake_array

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
    from lutbake.lut.bake import bake_array

    closed = bake_array(stiff_spec, "opencl", device=kernel_device).reshape(-1, 3)
    direct = bake_array(stiff_spec, "opencl", "direct", kernel_device).reshape(-1, 3)
    params = [np.ravel(p) for p in stiff_spec.cell_params(0, stiff_spec.image_size[1])]
    resolved = stiff_spec.truncation_estimate(*params) == 0
    beyond = series_colour(stiff_spec.texel_stacks(params)).path == 1
    assert (beyond & resolved).sum() > 100
    assert np.abs(closed - direct)[resolved].max() <= 1e-7


# The closed form's pass runs over the texels the plan counts in a band's rows (lutbake/integrate/series.py),
# and a band's value does not depend on how the image is cut into bands.


def _series_of(spec, device):
    from lutbake.integrate.opencl import OpenCLBackend

    fast = OpenCLBackend(spec.compute, device=device)
    return fast, fast._series_of(spec)


def test_plan_counts_per_row_the_texels_numpy_leaves_beyond_the_series(stiff_spec, kernel_device):
    _, series = _series_of(stiff_spec, kernel_device)
    width, height = stiff_spec.image_size
    params = [np.ravel(p) for p in stiff_spec.cell_params(0, height)]
    beyond = series_colour(stiff_spec.texel_stacks(params), integrate=False).path.reshape(height, width) > 0
    rest_per_row = series.plan().rest_per_row
    assert 0 < np.count_nonzero(rest_per_row) < height  # some rows hold none: their bands skip the pass
    np.testing.assert_array_equal(rest_per_row, beyond.sum(axis=1))


def _by_bands(fast, spec, rows_per_band):
    height = spec.image_size[1]
    return np.concatenate(
        [fast.bake_rows(spec, y, min(y + rows_per_band, height)) for y in range(0, height, rows_per_band)]
    )


def test_bands_of_any_height_give_the_same_bits(stiff_spec, kernel_device):
    fast, _ = _series_of(stiff_spec, kernel_device)
    whole = _by_bands(fast, stiff_spec, stiff_spec.image_size[1])
    for rows_per_band in (1, 3):
        assert np.array_equal(whole.view(np.uint64), _by_bands(fast, stiff_spec, rows_per_band).view(np.uint64))


def test_float32_bands_of_any_height_agree_to_an_ulp(stiff_spec, kernel_device):
    """float32: what the series leaves goes to the direct quadrature (the counts checked against the plan's
    on the way). Intel's runtime rounds a few texels one float32 ulp apart as the band's height moves them
    between its vector lanes and the scalar remainder (so did the code before the closed form's launch
    followed the plan); a bake cuts its bands alike every time, so its bytes do not move."""
    spec = replace(stiff_spec, compute="float32")
    fast, _ = _series_of(spec, kernel_device)
    whole = _by_bands(fast, spec, spec.image_size[1])
    ulp = np.spacing(whole.astype(np.float32)).astype(np.float64)
    for rows_per_band in (1, 3):
        assert np.all(np.abs(_by_bands(fast, spec, rows_per_band) - whole) <= ulp)


def test_a_band_that_leaves_other_texels_than_planned_raises(stiff_spec, kernel_device):
    fast, series = _series_of(stiff_spec, kernel_device)
    plan = series.plan()
    row = int(np.flatnonzero(plan.rest_per_row)[0])
    plan.rest_per_row[row] -= 1  # the plan now counts one texel fewer than the series leaves
    try:
        with pytest.raises(RuntimeError, match="where the plan counted"):
            fast.bake_rows(stiff_spec, row, row + 1)
    finally:
        plan.rest_per_row[row] += 1
