"""The float64 Airy reflectance against tmm, mpmath at 50 digits, and identities."""

import numpy as np
import pytest
import tmm
from airy_mp import backward_error_ratios, extreme_cases, random_cases
from hypothesis import example, given, settings
from hypothesis import strategies as st

from lutbake.physics.materials import material
from lutbake.physics.optics import film_amplitudes, film_reflectance, film_transmittance
from lutbake.physics.points import FilmPoints

U = np.finfo(float).eps / 2
_FIELDS = ("eta1", "eta2", "eta3", "kappa3", "cos_theta", "thickness_nm")


def _stack(eta1, eta2, eta3, kappa3, cos_theta, thickness_nm):
    """The stacks of cases listed as (η1, η2, η3, κ3, cos θ1, d[, λ]), as the mpmath oracle takes them."""
    return FilmPoints(eta1=eta1, eta2=eta2, eta3=eta3, kappa3=kappa3, cos_theta=cos_theta, thickness_nm=thickness_nm)


def test_matches_tmm_on_10000_random_cases(rng):
    cases = random_cases(rng, 10_000)
    eta1, eta2, eta3, kappa3, theta, d, lam = cases
    rs, rp, _ = film_reflectance(_stack(eta1, eta2, eta3, kappa3, np.cos(np.radians(theta)), d), lam)
    worst = 0.0
    for i in range(theta.size):
        stack = [eta1[i], eta2[i], eta3[i] + 1j * kappa3[i]]
        for pol, ours in (("s", rs[i]), ("p", rp[i])):
            ref = tmm.coh_tmm(pol, stack, [np.inf, d[i], np.inf], np.radians(theta[i]), lam[i])["R"]
            worst = max(worst, abs(ours - ref))
    assert worst <= 1e-9
    assert {0.0, 5000.0} <= set(d) and {0.0, 10.0} <= set(kappa3)


BACKWARD_U = 16  # the float64 R is the exact R of inputs each within 16u, rounded within 16u (checked below)


def _mp_errors(cases):
    """|R − R at 50 digits| (n, 2) over the cases, each divided by what rounding allows: lutbake/physics/optics.py is
    backward stable, its float64 R the exact R of inputs within BACKWARD_U·u of theirs, rounded within
    BACKWARD_U·u, so |ΔR| ≤ BACKWARD_U·u·(Σ_i |x_i ∂R/∂x_i| + 1): ≤ 1 where that holds. The conditioning
    near the critical angle, at grazing incidence and at high finesse is the sensitivity's, not a
    constant's (measured ≤ 1.1 u·(Σ + 1) on an AMD Zen 4)."""
    return backward_error_ratios(lambda case: film_reflectance(_stack(*case[:6]), case[6])[:2], cases, BACKWARD_U)


def test_matches_textbook_airy_at_50_digits(rng):
    cases = extreme_cases(rng)
    assert len(cases) >= 200
    assert _mp_errors(cases).max() <= 1


def test_thick_films_within_phase_conditioning_of_50_digits(rng):
    """Φ ~ 4000 rad: one ulp of Φ alone moves R by ~1e-13; the thickness's share of the sensitivity is Φ ∂R/∂Φ."""
    cases = extreme_cases(rng, thickness_nm=(5e4, 1e5))[::5]
    assert _mp_errors(cases).max() <= 1


@pytest.mark.parametrize("pol", [0, 1])
def test_zero_thickness_is_the_bare_ambient_base_interface(rng, pol):
    e1, e2, e3, k3, theta, _, lam = random_cases(rng, 500)
    c = np.cos(np.radians(theta))
    film = film_reflectance(_stack(e1, e2, e3, k3, c, 0.0), lam)[pol]
    bare = film_reflectance(_stack(e1, e1, e3, k3, c, 0.0), lam)[pol]
    assert np.max(np.abs(film - bare)) <= 1e-13


def test_film_matching_the_ambient_is_the_bare_interface(rng):
    e1, _, e3, k3, theta, d, lam = random_cases(rng, 500)
    c = np.cos(np.radians(theta))
    film = film_reflectance(_stack(e1, e1, e3, k3, c, d), lam)
    bare = film_reflectance(_stack(e1, e1, e3, k3, c, 0.0), lam)
    for a, b in zip(film, bare):
        assert np.max(np.abs(a - b)) <= 1e-12


def test_base_matching_the_film_is_the_ambient_film_interface(rng):
    e1, e2, _, _, theta, d, lam = random_cases(rng, 500)
    c = np.cos(np.radians(theta))
    film = film_reflectance(_stack(e1, e2, e2, 0.0, c, d), lam)
    g1, g2 = e1 * c, np.sqrt(e2**2 - e1**2 * (1 - c**2) + 0j)
    rs = np.abs((g1 - g2) / (g1 + g2)) ** 2
    rp = np.abs((e2**2 * g1 - e1**2 * g2) / (e2**2 * g1 + e1**2 * g2)) ** 2
    assert np.max(np.abs(film[0] - rs)) <= 1e-13
    assert np.max(np.abs(film[1] - rp)) <= 1e-13


def test_grazing_incidence_reflects_everything(rng):
    e1, e2, e3, k3, _, d, lam = random_cases(rng, 200)
    for c in (0.0, 1e-9):
        r = film_reflectance(_stack(e1, e2, e3, k3, c, d), lam)[2]
        assert np.all(np.abs(r - 1.0) <= 1e-7 if c else r == 1.0)
    # all three media alike at grazing incidence (0/0 in the raw formula)
    assert film_reflectance(_stack(1.0, 1.0, 1.0, 0.0, 0.0, 100.0), 500.0)[2] == 1.0


def test_energy_conservation_on_dielectric_bases(rng):
    e1, e2, e3, _, theta, d, lam = random_cases(rng, 5000)
    c = np.cos(np.radians(theta))
    r = film_reflectance(_stack(e1, e2, e3, 0.0, c, d), lam)
    t = film_transmittance(_stack(e1, e2, e3, 0.0, c, d), lam)
    for a, b in zip(r, t):
        assert np.max(np.abs(a + b - 1.0)) <= 1e-12


def test_transmittance_matches_tmm_on_absorbing_bases(rng):
    e1, e2, e3, _, theta, d, lam = random_cases(rng, 300)
    k3 = rng.uniform(0, 5, 300)
    t = film_transmittance(_stack(e1, e2, e3, k3, np.cos(np.radians(theta)), d), lam)
    for i in range(300):
        for pol, ours in (("s", t[0][i]), ("p", t[1][i])):
            ref = tmm.coh_tmm(
                pol, [e1[i], e2[i], e3[i] + 1j * k3[i]], [np.inf, d[i], np.inf], np.radians(theta[i]), lam[i]
            )["T"]
            assert abs(ours - ref) <= 1e-9


def test_named_materials_are_taken_at_each_wavelength():
    """A stack over gold: as_column() against M wavelengths gives (P, M), each R that of gold's index at
    that wavelength, as tmm computes it."""
    gold = FilmPoints.build(eta2=1.4, thickness_nm=[0.0, 150.0, 400.0], cos_theta=[1.0, 0.6, 0.2], base="Au")
    lam = np.linspace(360.0, 830.0, 12)
    r = film_reflectance(gold.as_column(), lam)[2]
    assert r.shape == (3, 12)
    eta3, kappa3 = material("Au").index(lam)
    for i in range(3):
        for j in range(12):
            stack = [1.0, 1.4, eta3[j] + 1j * kappa3[j]]
            theta = np.arccos(gold.cos_theta[i])
            ref = [tmm.coh_tmm(pol, stack, [np.inf, gold.thickness_nm[i], np.inf], theta, lam[j])["R"] for pol in "sp"]
            assert abs(r[i, j] - 0.5 * sum(ref)) <= 1e-9


def test_glass_at_normal_incidence_reflects_four_percent():
    assert film_reflectance(_stack(1.0, 1.5, 1.5, 0.0, 1.0, 123.0), 550.0)[2] == pytest.approx(0.04, abs=1e-15)


def test_brewster_angle_amplitude_is_continuous():
    """r_p crosses zero at Brewster's angle; its complex value moves continuously."""
    brewster = np.arctan(1.5)
    theta = brewster + np.linspace(-1e-6, 1e-6, 201)
    _, rp = film_amplitudes(_stack(1.0, 1.5, 1.5, 0.0, np.cos(theta), 0.0), 550.0)
    assert np.max(np.abs(np.diff(rp))) < 1e-7
    assert rp.real.min() < 0 < rp.real.max()


@settings(max_examples=400, deadline=None)
@given(
    eta1=st.floats(0.5, 3.0),
    eta2=st.floats(1.0, 4.0),
    eta3=st.floats(0.05, 5.0),
    kappa3=st.one_of(st.just(0.0), st.floats(0.0, 100.0)),
    cos_theta=st.one_of(st.sampled_from([0.0, 1e-12, 1.0]), st.floats(0.0, 1.0)),
    thickness=st.one_of(st.just(0.0), st.floats(0.0, 1e5)),
    lam=st.floats(360.0, 830.0),
)
@example(eta1=2.0, eta2=1.0, eta3=2.0, kappa3=0.0, cos_theta=5e-324, thickness=0.0, lam=360.0)  # p: 0/0 once
def test_reflectance_is_a_probability(eta1, eta2, eta3, kappa3, cos_theta, thickness, lam):
    rs, rp, r = film_reflectance(_stack(eta1, eta2, eta3, kappa3, cos_theta, thickness), lam)
    for v in (rs, rp, r):
        assert np.isfinite(v) and -1e-15 <= v <= 1 + 1e-12


def test_per_point_admittances_and_the_complement_where_taken_equal_the_per_node_evaluation(rng):
    """A stack's (P, 1) columns against M wavelengths: film_reflectance computes the admittances once per
    point and 1 − T only where |r|² > 1/2 (the ground truth's layout, 1.9x faster); every field broadcast to
    (P, M) first, with both branches taken by np.where over every node, gives the same to the rounding of a
    few operations (~40 U: the operands' order is the same, vectorized and scalar loops round alike up to an
    FMA)."""
    eta1, eta2, eta3, kappa3, theta, d, _ = random_cases(rng, 300)
    column = _stack(eta1, eta2, eta3, kappa3, np.cos(np.radians(theta)), d).as_column()
    lam = np.linspace(360.0, 830.0, 97)
    per_node = FilmPoints(**{f: np.broadcast_to(getattr(column, f), (300, 97)) for f in _FIELDS})
    r_s, r_p = (np.abs(r) ** 2 for r in film_amplitudes(per_node, lam))
    t_s, t_p, _ = film_transmittance(per_node, lam)
    expected = [np.where(r <= 0.5, r, 1.0 - t) for r, t in ((r_s, t_s), (r_p, t_p))]
    got = film_reflectance(column, lam)
    assert all(g.shape == (300, 97) for g in got)
    assert 0.1 < np.mean(r_s > 0.5) < 0.9  # both branches taken
    for g, e in zip(got, expected):
        np.testing.assert_allclose(g, e, rtol=0, atol=40 * U)
    np.testing.assert_allclose(got[2], 0.5 * (expected[0] + expected[1]), rtol=0, atol=40 * U)
