"""physics/fringes.py (the Airy reflectance as a function of its phase) against mpmath at 50 digits and against
optics.film_reflectance, at random, stiff and searched stacks; the points it leaves to optics."""

import numpy as np
import pytest
from airy_mp import backward_error_ratios, extreme_cases, optics_sensitivity, optics_sp, random_cases, stack_of

from lutbake.physics.fringes import MIN_FILM_COS, fringe_points, fringe_polarized, fringe_reflectance, fringe_terms
from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import unpolarized_reflectance

U = np.finfo(float).eps / 2
BACKWARD_U = 16  # the bound optics is held to (tests/physics/test_optics.py)


def _receipt_cases(rng, n):
    """(η1, η2, η3, κ3, cos θ1, d, λ) columns where the receipts' truth is dear: grazing incidence (cos θ1 down to
    1e-12) over near-totally reflecting metals (κ3 to 100), black bases (η3 = η1, κ3 = 0: the glTF mapping of a
    black metal), total reflection at a dielectric base, films up to 100 µm, film indices down to the ambient's
    (g2 → 0 at grazing incidence)."""
    eta1 = np.ones(n)
    eta2 = np.where(rng.random(n) < 0.8, rng.uniform(1.2, 2.5, n), rng.choice([1.0, 1 + 1e-12, 1 + 1e-6, 1.01], n))
    kind = rng.integers(0, 3, n)
    eta3 = np.choose(kind, [rng.uniform(0.05, 0.5, n), eta1, rng.uniform(1.0, 1.19, n)])
    kappa3 = np.choose(kind, [rng.uniform(3.0, 100.0, n), np.zeros(n), np.zeros(n)])
    cos = np.where(rng.random(n) < 0.5, rng.choice([1e-12, 1e-9, 1e-6, 1e-4, 1e-3, 1e-2], n), rng.random(n))
    d = np.where(rng.random(n) < 0.7, rng.uniform(0, 2000, n), rng.uniform(5e4, 1e5, n))
    return eta1, eta2, eta3, kappa3, cos, d, rng.uniform(360, 830, n)


def _corner_cases(rng, n):
    """The corner a report's search probes because the truth has no limit there (quality/measure.py's
    singular places): grazing incidence (cos θ1 to 1e-17) over a base within rounding of the ambient
    (η3 = η1(1 ± 1e-12) or η1, κ3 ~ cos² θ1), films down to nothing. |r12| and |r23| both round to 1 there
    while their difference sets R (6e-11 → 0.37 off before it came from the losses)."""
    cos = 10.0 ** rng.uniform(-17, -5, n)
    eta3 = rng.choice([1.0, 1 + 1e-12, 1 - 1e-12], n)
    kappa3 = np.where(rng.random(n) < 0.8, cos * cos * 10.0 ** rng.uniform(-1, 1, n), 0.0)
    d = np.where(rng.random(n) < 0.5, 10.0 ** rng.uniform(-15, 0, n), rng.uniform(0, 2000, n))
    return np.ones(n), rng.uniform(1.2, 2.5, n), eta3, kappa3, cos, d, rng.uniform(360, 830, n)


def _qualifying(cases):
    """The cases (rows) that fringe_points admits."""
    return [case for case in cases if fringe_points(stack_of(*case[:6]))[0]]


def _fringe_sp(case):
    return [r[0, 0] for r in fringe_polarized(fringe_terms(stack_of(*case[:6])), case[6])]


def test_matches_textbook_airy_at_50_digits(rng):
    """Backward stable as optics is: |ΔR| ≤ 16u·(Σᵢ |xᵢ ∂R/∂xᵢ| + 1), the sensitivity by mpmath (measured
    ≤ 0.1 of it on an AMD Zen 4). The stiff cases reach cos θ1 = 1e-12, films at their critical angle's
    edge, κ3 = 100, η3 = η2(1 ± 1e-12), Brewster, total reflection at the base, Φ ~ 4000 rad, and the
    singular corner (cos θ1 to 1e-17 over a base matching the ambient to rounding)."""
    stiff = extreme_cases(rng)[::2] + extreme_cases(rng, thickness_nm=(5e4, 1e5))[::5]
    receipts = list(zip(*_receipt_cases(rng, 150))) + list(zip(*_corner_cases(rng, 100)))
    cases = _qualifying(stiff + receipts)
    assert len(cases) >= 350
    assert backward_error_ratios(_fringe_sp, cases, BACKWARD_U).max() <= 1


def _ratio_to_both_bounds(columns):
    """|fringes − optics| / (2·16u·(Σ + 1)): each within 16u·(Σ + 1) of the exact R, so ≤ 1."""
    fringe = np.stack([r[:, 0] for r in fringe_polarized(fringe_terms(stack_of(*columns[:6])), columns[6][:, None])])
    return np.abs(fringe - optics_sp(columns)) / (2 * BACKWARD_U * U * (optics_sensitivity(columns) + 1))


def _search_worst(rng, columns, rounds=6):
    """Local search from the 20 worst stacks: each round moves every input by a random relative step
    (1e-3 to 1e-9) and keeps the moves that raise the ratio."""
    worst = np.argsort(_ratio_to_both_bounds(columns).max(axis=0))[-20:]
    best = [c[worst].copy() for c in columns]
    score = _ratio_to_both_bounds(best).max(axis=0)
    for _ in range(rounds):
        scale = 10.0 ** rng.uniform(-9, -3, (7, 20))
        moved = [c * (1 + scale[i] * rng.standard_normal(20)) for i, c in enumerate(best)]
        moved[4] = np.clip(moved[4], 0.0, 1.0)
        keep = fringe_points(stack_of(*moved[:6]))
        trial = np.where(keep, _ratio_to_both_bounds(moved).max(axis=0), -1.0)
        better = trial > score
        best = [np.where(better, m, b) for m, b in zip(moved, best)]
        score = np.maximum(score, trial)
    return score


def test_matches_optics_within_both_backward_bounds_at_random_and_searched_stacks(rng):
    """60,000 random and receipt-like stacks, then a local search for the worst: within the sum of both paths'
    backward bounds (measured ≤ 0.07 of it on an AMD Zen 4)."""
    random = np.array(random_cases(rng, 30_000))
    random[4] = np.cos(np.radians(random[4]))
    columns = np.hstack([random, np.array(_receipt_cases(rng, 25_000)), np.array(_corner_cases(rng, 5_000))])
    columns = columns[:, fringe_points(stack_of(*columns[:6]))]
    assert columns.shape[1] > 40_000
    assert _ratio_to_both_bounds(list(columns)).max() <= 1
    assert _search_worst(rng, list(columns)).max() <= 1


def test_a_sign_slip_in_a_phase_shift_breaks_the_bound(rng):
    """The comparison above can fail: β of the wrong sign (cos(Φ/2 − β)) moves R far past the bound."""
    columns = np.array(_receipt_cases(rng, 2000))
    columns = columns[:, fringe_points(stack_of(*columns[:6]))]
    terms = fringe_terms(stack_of(*columns[:6]))
    slipped = type(terms)(**{**vars(terms), "num_sin": -terms.num_sin})
    wrong = fringe_reflectance(slipped, columns[6][:, None])[:, 0]
    right = film_reflectance(stack_of(*columns[:6]), columns[6])[2]
    assert np.max(np.abs(wrong - right)) > 1e-3


def _cos_where_film_leans(cos_theta2, eta1=1.5, eta2=1.0):
    """cos θ1 where a film η2 under an ambient η1 carries cos θ2 (η2 cos θ2 = g2)."""
    return np.sqrt(1 - (1 - cos_theta2**2) * (eta2 / eta1) ** 2)


@pytest.mark.parametrize(
    ("stack", "why"),
    [
        ((1.0, 1.5, 0.2, 3.0, 0.0, 300.0), "grazing incidence"),
        ((1.0, 1.5, 0.2, 3.0, 5e-324, 300.0), "subnormal cos θ1"),
        ((1.0, 1.5, 0.2, 3.0, 1e-31, 300.0), "cos θ1 below MIN_COS"),
        ((1.5, 1.0, 1.0, 0.0, _cos_where_film_leans(0.5 * MIN_FILM_COS), 300.0), "film past arccos(MIN_FILM_COS)"),
        ((1.5, 1.0, 1.0, 0.0, 0.5, 300.0), "film less dense than the ambient, evanescent"),
    ],
)
def test_stacks_outside_the_model_are_left_to_optics(stack, why):
    """fringe_points refuses them, and the truth's reflectance there is optics' bit for bit."""
    assert not fringe_points(stack_of(*stack))[0], why
    lam = np.linspace(360.0, 830.0, 11)
    expected = film_reflectance(stack_of(*stack).as_column(), lam)[2]
    assert np.array_equal(unpolarized_reflectance(stack_of(*stack), lam), expected)


def test_the_truth_takes_each_point_from_its_own_path():
    """A mix of admitted and refused stacks (one named material among them): each row is its own path's."""
    mixed = stack_of([1.0, 1.0, 2.0], [1.5, 1.5, 1.5], [0.2, 0.2, 1.0], [3.0, 3.0, 0.0], [0.4, 0.0, 0.3], 300.0)
    lam = np.linspace(360.0, 830.0, 7)
    got = unpolarized_reflectance(mixed, lam)
    assert fringe_points(mixed).tolist() == [True, False, False]
    assert np.array_equal(got[0], fringe_reflectance(fringe_terms(stack_of(1.0, 1.5, 0.2, 3.0, 0.4, 300.0)), lam)[0])
    assert np.array_equal(got[1:], film_reflectance(stack_of(*(c[1:] for c in _columns(mixed))).as_column(), lam)[2])
    gold = FilmPoints.build(eta2=1.4, thickness_nm=[150.0], cos_theta=[0.6], base="Au")
    assert not fringe_points(gold).any()
    assert np.array_equal(unpolarized_reflectance(gold, lam), film_reflectance(gold.as_column(), lam)[2])


def _columns(stack):
    return [stack.eta1, stack.eta2, stack.eta3, stack.kappa3, stack.cos_theta, stack.thickness_nm]
