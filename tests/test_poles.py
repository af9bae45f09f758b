"""The poles' closed form (lutbake.poles) against independent references: quadrature of the Cauchy
transform, a converged Gauss–Legendre quadrature of the whole integral in long double, the converged
series, the ground truth, and the kernel's direct quadrature."""

import functools

import mpmath as mp
import numpy as np
import pytest

from lutbake.colorimetry import colorimetry
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


LONG = np.longdouble
U_LONG = float(np.finfo(LONG).eps) / 2   # 2^-64 on x86-64; where long double is double, the model grows with it
U_DOUBLE = float(np.finfo(float).eps) / 2
REFERENCE_NODES = 32


@functools.lru_cache(maxsize=1)
def _gauss_legendre_long():
    """32-point Gauss–Legendre nodes and weights on [−1, 1], and 2π, from mpmath at 40 digits (Newton on
    the Legendre recurrence), each rounded once to long double. numpy's leggauss is no reference here:
    its weights' error grows with the node count (hundreds of ε at 32 nodes; at 2,048 it put the former
    reference 1.5e-12 off)."""
    n = REFERENCE_NODES
    with mp.workdps(40):
        def legendre(t):   # P_n(t), P_{n−1}(t)
            p0, p1 = mp.mpf(1), t
            for k in range(2, n + 1):
                p0, p1 = p1, ((2 * k - 1) * t * p1 - (k - 1) * p0) / k
            return p1, p0
        nodes, weights = [], []
        for i in range(n):
            t = mp.cos(mp.pi * (i + 0.75) / (n + 0.5))
            for _ in range(100):
                p, p_before = legendre(t)
                step = p * (t * t - 1) / (n * (t * p - p_before))
                t -= step
                if abs(step) < mp.mpf(10) ** -36:
                    break
            nodes.append(mp.nstr(t, 30))
            weights.append(mp.nstr(2 * (1 - t * t) / (n * legendre(t)[1]) ** 2, 30))
        two_pi = mp.nstr(2 * mp.pi, 30)
    return np.array(nodes, LONG), np.array(weights, LONG), LONG(two_pi)


def _film_poles_nm(q, X):
    """The complex λ (Im > 0) where q e^{i2πX/λ} = 1, i.e. 2πX/λ = 2πk − arg q + i log|q|, for the k
    whose real part falls within 2 nm of the band."""
    arg, log_abs = np.angle(q), np.log(np.abs(q))
    k = np.arange(np.ceil((2 * np.pi * X / 832.0 + arg) / (2 * np.pi)),
                  np.floor((2 * np.pi * X / 358.0 + arg) / (2 * np.pi)) + 1)
    return 2 * np.pi * X / (2 * np.pi * k - arg + 1j * log_abs)


def _graded_pieces(poles_nm):
    """[a, b] pieces of [360, 830] nm: the 1 nm panels (w_c is linear on each) cut at Re P ± Im P·2^j
    (j ≥ 0, to 2 nm) around every pole P, so each piece lies at least its half-length from every pole:
    its Bernstein ρ ≥ 1 + √2, checked here, where 32 Gauss–Legendre nodes leave ρ^−64 < 4e-25 of the
    piece's integrand."""
    edges = [np.arange(360.0, 831.0)]
    for p in poles_nm:
        steps = p.imag * 2.0 ** np.arange(max(1, int(np.ceil(np.log2(2.0 / p.imag)))) + 1)
        edges += [p.real + steps, p.real - steps]
    cuts = np.unique(np.clip(np.concatenate(edges), 360.0, 830.0))
    a, b = cuts[:-1], cuts[1:]
    if len(poles_nm):
        t = (np.asarray(poles_nm)[None, :] - 0.5 * (a + b)[:, None]) / (0.5 * (b - a)[:, None])
        s = np.sqrt(t - 1) * np.sqrt(t + 1)
        assert np.maximum(np.abs(t + s), np.abs(t - s)).min() >= 2.4
    return a, b


def _reference_quadrature(K, q, X):
    """∫ w_c K z/(1 − q z) dλ (n, 3) and a first-order bound on its rounding (n, 3): 32-node Gauss–Legendre
    on the pieces of _graded_pieces, in long double, w_c the 1 nm table's linear interpolation.

    The integrand peaks at |K|/(1 − |q|), and an error δ in the node or the phase φ = 2πX/λ moves it by
    δ/|1 − q z|: in double that rounding alone reaches 1e-12 here. Per node, with u long double's unit
    roundoff and W = w_c(λ)·h·ω (h the piece's half-length, ω the rule's weight):
      node λ = m + h x: m, h exact (float64 ends, 64-bit significand), x, h·x and the sum rounded: moved ≤ 2uλ;
      φ: 2π, ·X and /λ rounded: 3u, with the node's 2u: |δφ| ≤ 5uφ;  z = e^{iφ}: cos, sin within
      4 ulp (8u), so |δz| ≤ 8u; z enters f as δz/(z(1 − q z)): (5φ + 8)u/|1 − q z|;
      q z: √5 u|q| (complex product), over |1 − q z|;  1 − q z: u;  K z: √5 u;  the division: 8u
      (Higham, Accuracy and Stability, §3.6: √2γ_4 for the textbook formula);  W's three products: 3u;
      W·f: u; together 16u with the rest rounded up;  w_c(λ) = y0 + (y1 − y0)(λ − j): 3u(|y0| + |y1|),
      and the node's move 2uλ|y1 − y0|: (3 + 2λ)u(|y0| + |y1|)·hω·|f|;
      the sum of N terms, in any order: √2 γ_N Σ|W f|;  the result rounded to float64: u_double|I|.
    Summed over the nodes: the bound returned (the rule's own error, ρ^−64, is below 1e-22 here)."""
    x, omega, two_pi = _gauss_legendre_long()
    table = colorimetry("cie1931", "rec709").rgb_table                 # (3, 471): 360 … 830 nm
    integral, rounding = np.empty((K.size, 3), complex), np.empty((K.size, 3))
    for i in range(K.size):
        a, b = _graded_pieces(_film_poles_nm(q[i], X[i]))
        m, h = (LONG(a) + LONG(b)) / 2, (LONG(b) - LONG(a)) / 2
        lam, h_omega = (m[:, None] + h[:, None] * x).ravel(), (h[:, None] * omega).ravel()
        j = np.minimum(np.floor(lam), 829).astype(int)
        y0, y1 = table[:, j - 360].astype(LONG), table[:, j - 359].astype(LONG)
        w = y0 + (y1 - y0) * (lam - j)
        phase = two_pi * LONG(X[i]) / lam
        z = np.exp(1j * phase)
        one_minus_qz = 1 - q[i] * z
        f = K[i] * z / one_minus_qz
        integral[i] = ((w * h_omega) * f).sum(axis=1).astype(complex)
        size = h_omega * np.abs(f)                                          # (N,)
        per_node = size * (np.abs(w) * ((5 * phase + 8 + np.sqrt(5) * abs(q[i])) / np.abs(one_minus_qz) + 16)
                           + (np.abs(y0) + np.abs(y1)) * (3 + 2 * lam))
        n = lam.size
        summed = np.sqrt(2) * n * U_LONG / (1 - n * U_LONG) * (size * np.abs(w)).sum(axis=1)
        rounding[i] = (U_LONG * per_node.sum(axis=1) + summed).astype(float) + U_DOUBLE * np.abs(integral[i])
    return integral, rounding


def test_closed_form_equals_a_converged_quadrature_within_both_bounds(rng):
    """The closed form against _reference_quadrature at 24 stiff cases, per channel: within the closed
    form's a-priori bound plus the quadrature's rounding bound (the latter ≤ 0.44 of the former over 200
    seeds of these cases, so an error of 1.5× the bound fails). The closed form's bound leaves out its own
    float64 rounding (lutbake/poles.py states none): beyond the quadrature's bound, its error measured
    ≤ 0.17 of the bound over those 200 seeds (AMD Zen 4, numpy 2.4)."""
    K, q, X = _stiff_cases(rng, 24)
    result = closed_form(K, q, X)
    assert result.ok.all() and (result.near_poles > 0).sum() >= 6   # a quarter at least: poles near the band
    reference, rounding = _reference_quadrature(K, q, X)
    assert (np.abs(result.integral - reference) <= result.bound[:, None] + rounding).all()
    assert (result.bound <= 1e-9 * np.abs(K)).all()   # within the series' tolerance: the closed form is used


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
