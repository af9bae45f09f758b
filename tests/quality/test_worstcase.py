"""The generic worst-case search (lutbake/quality/worstcase.py) against functions whose maxima are known exactly:
a narrow peak that random points miss, a corner, an edge, a singular place the caller names, a discrete
axis. Each premise ("random points miss it") is asserted beside the search's result."""

import doctest

import numpy as np
import pytest

import lutbake.quality.worstcase
from lutbake.quality.worstcase import SearchAxis, find_worst

AXES4 = (SearchAxis("a", cells=16), SearchAxis("b", cells=32), SearchAxis("c", cells=8), SearchAxis("d", cells=8))


def _random_max(error, d, n=5000, seed=1):
    return float(error(np.random.default_rng(seed).uniform(size=(n, d))).max())


def _cone(centre, radius):
    """1 at ``centre``, falling linearly to 0 at ``radius`` and 0 beyond: no slope to climb from outside,
    so only a start inside finds it."""

    def error(u):
        return np.maximum(0.0, 1.0 - np.linalg.norm(u - centre, axis=1) / radius)

    return error


def test_a_narrow_interior_peak_is_found_and_climbed_to_its_top():
    """A Lorentzian 0.003 wide at an off-grid point: 5,000 random points reach < 0.1 of it; the search
    reaches its top (1 exactly) to 1e-3, within 1e-4 of its place (its last steps are a ten-thousandth of a
    cell)."""
    centre = np.array([0.4137, 0.2718, 0.8123, 0.0931])

    def error(u):
        return 1.0 / (1.0 + np.sum(((u - centre) / 0.003) ** 2, axis=1))

    assert _random_max(error, 4) < 0.1
    calls = []
    worst = find_worst(lambda u: calls.append(len(u)) or error(u), AXES4, budget=20000)
    assert worst.value == pytest.approx(1.0, abs=1e-3)
    assert np.abs(worst.where - centre).max() < 1e-4
    # the budget is kept, counted as the function saw it, and spent (the rest refines other starts)
    assert 0.95 * 20000 <= sum(calls) == worst.evaluations <= 20000


def test_a_corner_maximum_is_found_by_the_corner_starts():
    """A cone of radius 0.03 at the corner (1, 0, 1, 0), flat zero elsewhere: random points and a
    climb from anywhere else see 0; the corner starts see 1."""
    error = _cone(np.array([1.0, 0.0, 1.0, 0.0]), 0.03)
    assert _random_max(error, 4) == 0.0
    worst = find_worst(error, AXES4, budget=6000)
    assert worst.value == 1.0 and worst.where.tolist() == [1.0, 0.0, 1.0, 0.0]
    assert worst.best.found_by == "corner"


def test_an_edge_maximum_is_found_along_the_edge_and_refined():
    """Non-zero only within 0.02 of the edge a = 1, c = 0, d = 1, peaking at b = 0.37 on it (value 1):
    found from the edge starts and refined to b = 0.37."""

    def error(u):
        off_edge = np.max(np.abs(u[:, [0, 2, 3]] - [1.0, 0.0, 1.0]), axis=1)
        return np.maximum(0.0, 1.0 - off_edge / 0.02) * (1.0 - (u[:, 1] - 0.37) ** 2)

    assert _random_max(error, 4) == 0.0
    worst = find_worst(error, AXES4, budget=8000)
    assert worst.value == pytest.approx(1.0, abs=1e-6)
    assert worst.where[[0, 2, 3]].tolist() == [1.0, 0.0, 1.0] and worst.where[1] == pytest.approx(0.37, abs=1e-3)
    assert worst.best.found_by in ("edge along b", "near edge along b") and worst.best.steps > 0


def test_a_peak_beside_a_hill_is_found_by_the_scatter_near_the_best_starts():
    """A hill (0.3, 0.15 wide) that random starts find and climb, and 0.07 from its top a cone of radius
    0.03 (value 1) that no climb sees (it is 0 outside): the scatter within two cells of the best starts
    lands in it at half the seeds or more (without that scatter, at none of these four)."""
    top, peak = np.full(4, 0.5), np.array([0.54, 0.54, 0.46, 0.54])
    cone = _cone(peak, 0.03)

    def error(u):
        return np.maximum(0.3 * np.exp(-np.sum((u - top) ** 2, axis=1) / (2 * 0.15**2)), cone(u))

    assert _random_max(error, 4) < 0.31
    found = [find_worst(error, AXES4, budget=10000, seed=seed) for seed in range(4)]
    peaks = [w for w in found if w.value > 0.99]
    assert len(peaks) >= 2 and all(w.best.found_by.startswith("near ") for w in peaks)


def _on_a_plane(u):
    """Non-zero only within 1e-6 of the plane c = 0.2371, peaking (value 1) at (0.6, 0.3, ·, 0.8)."""
    near = np.maximum(0.0, 1.0 - np.abs(u[:, 2] - 0.2371) / 1e-6)
    return near * np.exp(-np.sum((u[:, [0, 1, 3]] - [0.6, 0.3, 0.8]) ** 2, axis=1))


def test_a_named_singular_place_is_searched():
    """The plane c = 0.2371, named by the caller, is seeded and the maximum on it climbed to; without the
    name the same budget finds nothing (random points and corners and edges all miss the plane)."""
    named = find_worst(_on_a_plane, AXES4, singular={"c → 0.2371": {"c": 0.2371}}, budget=8000)
    assert named.value == pytest.approx(1.0, abs=1e-5)
    assert np.abs(named.where - [0.6, 0.3, 0.2371, 0.8]).max() < 1e-3
    assert named.best.found_by.startswith("singular: c → 0.2371, ")
    assert find_worst(_on_a_plane, AXES4, budget=8000).value == 0.0


def test_intersections_of_singular_places_are_seeded_with_their_corners_and_edges():
    """A cone of radius 0.02 on an edge of the intersection of two named places (a = 0.5, b = 0.25; at
    d = 1, c = 0.7): found from that face's edge along c, and not from either place alone."""
    error = _cone(np.array([0.5, 0.25, 0.7, 1.0]), 0.02)
    places = {"a mid": {"a": 0.5}, "b quarter": {"b": 0.25}}
    worst = find_worst(error, AXES4, singular=places, budget=8000)
    assert worst.value == pytest.approx(1.0, abs=1e-3)
    assert worst.best.found_by == "singular: a mid & b quarter, edge along c"
    for one in places:
        assert find_worst(error, AXES4, singular={one: places[one]}, budget=8000).value == 0.0


def test_places_that_fix_every_axis_together_seed_their_single_point():
    """Four places, one per axis: their intersection is one point, and a cone of radius 1e-3 there is
    found (from that point, or a climb nearby)."""
    at = np.array([0.11, 0.52, 0.33, 0.94])
    places = {name: {name: float(u)} for name, u in zip("abcd", at)}
    worst = find_worst(_cone(at, 1e-3), AXES4, singular=places, budget=8000)
    assert worst.value == 1.0 and worst.best.found_by == "singular: a & b & c & d, corner"


def test_a_discrete_axis_is_enumerated_and_held_while_refining():
    """Level 2 of 4 carries the peak; the search reports that level exactly (u = 2/3), never between."""
    axes = (SearchAxis("x", cells=10), SearchAxis("y", cells=10), SearchAxis("kind", levels=4))

    def error(u):
        level = np.round(u[:, 2] * 3)
        assert np.allclose(u[:, 2] * 3, level)  # only levels are ever evaluated
        return np.where(level == 2, 2.0, 1.0) / (1.0 + np.sum(((u[:, :2] - [0.31, 0.77]) / 0.02) ** 2, axis=1))

    worst = find_worst(error, axes, budget=6000)
    assert worst.value == pytest.approx(2.0, abs=1e-4) and worst.where[2] == pytest.approx(2 / 3)


def test_given_points_start_the_search_and_are_not_recounted():
    """A held-out point near a narrow cone starts a climb to its top (to 5e-3: a cone falls linearly and
    the last steps are 1.25e-5 here); points given with their errors cost no evaluation."""
    centre = np.array([0.7, 0.1, 0.5, 0.5])
    error = _cone(centre, 0.004)
    near = centre + 0.0015
    worst = find_worst(error, AXES4, points=[near], errors=error(near[None]), budget=3000)
    assert worst.value == pytest.approx(1.0, abs=5e-3) and worst.best.found_by == "given point"
    assert worst.starts["given point"] == 1 and worst.evaluations <= 3000


def test_nan_counts_as_the_worst_and_the_budget_is_kept():
    def error(u):
        return np.where(np.all(u == 1.0, axis=1), np.nan, u.sum(axis=1))

    worst = find_worst(error, AXES4, budget=1000)
    assert worst.value == np.inf and worst.where.tolist() == [1.0] * 4 and worst.evaluations <= 1000


def test_same_seed_same_result_and_the_candidates_are_distinct_maxima():
    """Two separated peaks of heights 1 and 0.5: the candidates list both, best first."""

    def error(u):
        return 1.0 / (1.0 + np.sum(((u - 0.2) / 0.05) ** 2, axis=1)) + 0.5 / (
            1.0 + np.sum(((u - 0.8) / 0.05) ** 2, axis=1)
        )

    first, again = find_worst(error, AXES4, budget=5000, seed=4), find_worst(error, AXES4, budget=5000, seed=4)
    assert first.describe() == again.describe()
    values = [c.value for c in first.candidates]
    assert values == sorted(values, reverse=True)
    assert values[0] == pytest.approx(1.0, abs=1e-3)
    assert any(abs(v - 0.5) < 2e-3 and np.allclose(c.where, 0.8, atol=1e-2) for v, c in zip(values, first.candidates))


def test_bad_arguments_are_refused_in_one_line():
    with pytest.raises(ValueError, match="budget 10 is too small: the box's 16 corners"):
        find_worst(lambda u: u[:, 0], AXES4, budget=10)
    with pytest.raises(ValueError, match="singular place 'x' names axis 'z': allowed a, b, c, d"):
        find_worst(lambda u: u[:, 0], AXES4, singular={"x": {"z": 0.0}}, budget=1000)


def test_the_module_examples_run():
    assert doctest.testmod(lutbake.quality.worstcase).failed == 0
