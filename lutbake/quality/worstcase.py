"""Worst-case search: the largest value of an error function over a box, searched rather than sampled.

A maximum over random points is a lower bound, and a loose one where the error peaks narrowly: an
interpolated table errs most between its nodes and where its content changes fastest, which is often at
an end of an axis or where the physics is singular (a film of zero thickness, grazing incidence, a base
that matches the ambient). ``find_worst`` looks where a maximum is likely, then climbs:

1. Starts: the caller's points (e.g. held-out points already scored), every corner of the box, points
   along every edge, points on the singular places the caller names (faces such as D = 0 or cos θ = 0,
   and their intersections: the corners and edges of each and a random scatter on it), a random
   scatter, and then a scatter within two cells of the best of those (a narrow peak sits among cells
   that err already).
2. The best starts, one per place (no two within a cell of each other), are refined by compass search
   (Kolda, Lewis & Torczon 2003): all 2·d axis steps of every start are evaluated in one call, each start
   moves to its best improving step, and halves its steps when none improves, until they are a
   ten-thousandth of a cell. Starts are refined, best first, until the evaluation budget is spent.
3. The result: the largest error, where (unit coordinates), how it was found (the start's kind and the
   steps that improved it), the evaluations spent, and the distinct local maxima found, best first, for
   a caller that re-scores them with a costlier truth.

The search knows nothing of what it measures. ``error`` is vectorised: (n, d) coordinates in the unit
cube → (n,) errors (NaN counts as +inf: a broken value is the worst). Coordinates are each axis's
normalized node coordinate (after its warp), so one cell of a grid has the same width along an axis;
an axis may also be discrete (a base kind: ``levels`` values at u = i / (levels − 1)), enumerated at the
corners, edges and faces and held fixed while refining.

Reference: T. G. Kolda, R. M. Lewis, V. Torczon, "Optimization by direct search: new perspectives on
some classical and modern methods", SIAM Review 45 (2003) 385–482 (compass search, section 3).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

# error(u) -> e: (n, d) unit coordinates to (n,) errors
ErrorFunction = Callable[[np.ndarray], npt.ArrayLike]
# a named singular place: axis name -> unit coordinate
Places = dict[str, dict[str, float]]

__all__ = ["SearchAxis", "Candidate", "WorstCase", "find_worst"]

# Shares of the budget for the starts; the rest (at least 40 %) refines.
_EDGE_SHARE, _SINGULAR_SHARE, _RANDOM_SHARE, _NEAR_SHARE = 0.15, 0.15, 0.1, 0.2
_NEAR_PLACES, _NEAR_CELLS = 32, 2  # scatter around the best places, within 2 cells on every axis
_UNGRIDDED_CELLS = 8  # cell width assumed on an axis without a grid
_FINAL_STEP_CELLS = 1e-4  # compass steps stop below this fraction of a cell
_STEPS_PER_START = 50  # compass iterations a start is expected to take (sizes each batch)


@dataclass(frozen=True)
class SearchAxis:
    """One axis of the searched box, [0, 1] in its node coordinate.

    Parameters
    ----------
    name : str
        What the axis is (reported in ``WorstCase.where_named``).
    cells : int
        Grid cells along the axis (node count − 1), 0 when there is no grid: edge starts sit at cell
        centres, the first compass step is half a cell, and points less than a cell apart are one place.
    levels : int
        0 for a continuous axis; otherwise a discrete axis of ``levels`` values at u = i / (levels − 1)
        (u = 0 when ``levels`` is 1), never stepped by the compass search.
    """

    name: str
    cells: int = 0
    levels: int = 0

    @property
    def discrete(self) -> bool:
        return self.levels > 0

    @property
    def cell_width(self) -> float:
        return 1.0 / (self.cells or _UNGRIDDED_CELLS)

    def level_values(self) -> np.ndarray:
        return np.linspace(0.0, 1.0, self.levels) if self.levels > 1 else np.zeros(1)

    def ends(self) -> np.ndarray:
        """The axis's values at a corner of the box: both ends, or every level of a discrete axis."""
        return self.level_values() if self.discrete else np.array([0.0, 1.0])


@dataclass(frozen=True)
class Candidate:
    """A local maximum: its error, where (unit coordinates), the start's kind, the error there and the
    compass steps that improved on it."""

    value: float
    where: np.ndarray = field(repr=False)
    found_by: str
    start_value: float
    steps: int

    def how(self) -> str:
        return self.found_by + (f", then {self.steps} compass steps" if self.steps else "")


@dataclass
class WorstCase:
    """The largest error found (``value``), its place and history, and what the search cost.

    ``candidates`` are the distinct local maxima found, best first (the first is the worst case).
    """

    axes: tuple[SearchAxis, ...]
    candidates: list[Candidate]
    evaluations: int
    budget: int
    starts: dict[str, int]  # start kind → how many were evaluated

    @property
    def best(self) -> Candidate:
        return self.candidates[0]

    @property
    def value(self) -> float:
        return self.best.value

    @property
    def where(self) -> np.ndarray:
        return self.best.where

    @property
    def where_named(self) -> dict[str, float]:
        return {a.name: float(u) for a, u in zip(self.axes, self.best.where)}

    def describe(self) -> dict:
        """JSON-ready: the worst error, where, how it was found and what the search cost."""
        return {
            "value": self.value,
            "where_unit": self.where_named,
            "found_by": self.best.how(),
            "start_value": self.best.start_value,
            "evaluations": self.evaluations,
            "budget": self.budget,
            "starts": dict(self.starts),
        }


def find_worst(
    error: ErrorFunction,
    axes: Iterable[SearchAxis],
    *,
    points: npt.ArrayLike | None = None,
    errors: npt.ArrayLike | None = None,
    singular: Places | None = None,
    budget: int = 20000,
    seed: int = 0,
    max_candidates: int = 10,
) -> WorstCase:
    """Search for the largest value of ``error`` over the unit box of ``axes``.

    Parameters
    ----------
    error : callable
        ``error(u) -> e``: u (n, d) unit coordinates, one column per axis; e (n,) errors.
    axes : sequence of SearchAxis
        The box's axes, in the column order of ``u``.
    points : array_like, optional
        (m, d) unit coordinates to start from as well (e.g. held-out points); ``errors`` their errors
        when already measured (they are then not evaluated again, nor counted).
    singular : dict, optional
        Named singular places: name → {axis name: unit coordinate}, e.g. ``{"D → 0": {"opd_nm": 0.0}}``.
        Each place, and each intersection of places on different axes, is seeded with its corners, its
        edges and a random scatter.
    budget : int
        Most evaluations of ``error`` (the corners alone must fit in half of it).
    seed : int
        The random scatter's seed (the same seed and budget give the same result).
    max_candidates : int
        Distinct local maxima kept in the result.

    Returns
    -------
    WorstCase

    Examples
    --------
    A peak 0.004 wide that 2,000 random points miss, found and climbed to its top:

    >>> import numpy as np
    >>> from lutbake.quality.worstcase import SearchAxis, find_worst
    >>> peak = np.array([0.3141, 0.7182])
    >>> def error(u):
    ...     return 1.0 / (1.0 + np.sum(((u - peak) / 0.004) ** 2, axis=1))
    >>> axes = (SearchAxis("x", cells=16), SearchAxis("y", cells=16))
    >>> bool(error(np.random.default_rng(0).uniform(size=(2000, 2))).max() < 0.6)
    True
    >>> worst = find_worst(error, axes, budget=4000)
    >>> round(worst.value, 4), worst.where.round(4).tolist(), worst.evaluations <= 4000
    (1.0, [0.3141, 0.7182], True)
    """
    axes = tuple(axes)
    rng = np.random.default_rng(seed)
    counter = _Counter(error, budget)
    u, e, kinds = _starts(counter, axes, points, errors, singular or {}, rng)
    order = _distinct(axes, u, np.argsort(-e, kind="stable"), limit=max(4 * counter.left // _per_start(axes), 1))
    found = _refine_in_batches(counter, axes, u[order], e[order], kinds[order])
    candidates = _distinct_candidates(axes, found, max_candidates)
    counts = dict(zip(*np.unique(kinds, return_counts=True)))
    return WorstCase(axes, candidates, counter.used, budget, {str(k): int(n) for k, n in counts.items()})


def _starts(
    counter: _Counter,
    axes: tuple[SearchAxis, ...],
    points: npt.ArrayLike | None,
    errors: npt.ArrayLike | None,
    singular: Places,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase 1, (u, e, kinds) of every start: the given points, the corners, edges and singular faces, a
    random scatter, then a scatter near the best of those; each evaluated (the given ones unless their
    ``errors`` are known) within the budget's shares."""
    budget = counter.budget
    corners = _corners(axes)
    if len(corners) > budget // 2:
        raise ValueError(
            f"budget {budget} is too small: the box's {len(corners)} corners need at least "
            f"{2 * len(corners)} evaluations"
        )
    pools = [
        ("corner", corners),
        *_edges(axes, int(_EDGE_SHARE * budget)),
        *_singular_faces(axes, singular, int(_SINGULAR_SHARE * budget), rng),
        ("random", _snap(axes, rng.uniform(size=(int(_RANDOM_SHARE * budget), len(axes))))),
    ]
    starts: list[np.ndarray] = []
    values: list[np.ndarray] = []
    kinds: list[str] = []
    if points is not None and np.size(points):
        given = np.asarray(points, float).reshape(-1, len(axes))
        starts.append(given)
        values.append(_clean(np.asarray(errors, float)) if errors is not None else counter(given))
        kinds += ["given point"] * len(given)
    for kind, u in pools:
        if len(u):
            starts.append(u)
            values.append(counter(u))
            kinds += [kind] * len(u)
    u, e, labels = np.vstack(starts), np.concatenate(values), np.array(kinds)
    near, near_kinds = _near(axes, u, e, labels, int(_NEAR_SHARE * budget), rng)
    return np.vstack([u, near]), np.concatenate([e, counter(near)]), np.concatenate([labels, near_kinds])


class _Counter:
    """``error`` with NaN as +inf, counting evaluations against the budget."""

    def __init__(self, error: ErrorFunction, budget: int) -> None:
        self.error, self.budget, self.used = error, budget, 0

    @property
    def left(self) -> int:
        return self.budget - self.used

    def __call__(self, u: np.ndarray) -> np.ndarray:
        self.used += len(u)
        return _clean(np.asarray(self.error(u), float).reshape(len(u)))


def _clean(e: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(e), np.inf, e)


def _snap(axes: Sequence[SearchAxis], u: npt.ArrayLike) -> np.ndarray:
    """Discrete axes' coordinates moved to their nearest level."""
    u = np.array(u, float)
    for i, a in enumerate(axes):
        if a.discrete:
            levels = a.level_values()
            u[:, i] = levels[np.argmin(np.abs(u[:, i, None] - levels), axis=1)]
    return u


def _product(columns: Sequence[np.ndarray]) -> np.ndarray:
    """Every combination of the columns' values, (n, len(columns)); one empty row for no columns."""
    return np.array(list(itertools.product(*columns)), float).reshape(-1, len(columns)) if columns else np.zeros((1, 0))


def _corners(axes: Sequence[SearchAxis]) -> np.ndarray:
    return _product([a.ends() for a in axes])


def _edges(axes: tuple[SearchAxis, ...], share: int) -> list[tuple[str, np.ndarray]]:
    """Points along every edge (one continuous axis free, the others at their ends), at cell centres of
    the free axis, thinned evenly when the edges would take more than ``share`` evaluations."""
    free = [i for i, a in enumerate(axes) if not a.discrete]
    per_axis = {i: axes[i].cells or _UNGRIDDED_CELLS for i in free}
    others = {i: _corners(axes[:i] + axes[i + 1 :]) for i in free}
    total = sum(per_axis[i] * len(others[i]) for i in free)
    thin = min(1.0, share / total) if total else 1.0
    out = []
    for i in free:
        n = max(2, int(per_axis[i] * thin))
        along = (np.arange(n) + 0.5) / n
        u = np.insert(np.repeat(others[i], n, axis=0), i, np.tile(along, len(others[i])), axis=1)
        out.append((f"edge along {axes[i].name}", u))
    return out


def _singular_faces(
    axes: tuple[SearchAxis, ...], singular: Places, share: int, rng: np.random.Generator
) -> list[tuple[str, np.ndarray]]:
    """Each named place and each intersection of places on different axes (a face of the box): its
    corners, its edges and a random scatter over it, ``share`` evaluations in all."""
    index = {a.name: i for i, a in enumerate(axes)}
    for name, at in singular.items():
        unknown = set(at) - set(index)
        if unknown:
            raise ValueError(f"singular place {name!r} names axis {sorted(unknown)[0]!r}: allowed {', '.join(index)}")
    faces = []
    for r in range(1, len(singular) + 1):
        for combo in itertools.combinations(singular.items(), r):
            fixed = {index[a]: u for _, at in combo for a, u in at.items()}
            if sum(len(at) for _, at in combo) == len(fixed):  # no axis fixed twice
                faces.append((" & ".join(name for name, _ in combo), fixed))
    out = []
    for name, fixed in faces:
        free = tuple(a for i, a in enumerate(axes) if i not in fixed)
        pools = [("corner", _corners(free)), *_edges(free, share // (2 * len(faces)))]
        used = sum(len(u) for _, u in pools)
        pools.append(("scatter", _snap(free, rng.uniform(size=(max(share // len(faces) - used, 0), len(free))))))
        out += [(f"singular: {name}, {kind}", _with_fixed(u, fixed, len(axes))) for kind, u in pools]
    return out


def _with_fixed(u_free: np.ndarray, fixed: dict[int, float], d: int) -> np.ndarray:
    """Points of a face, given on its free axes, in the whole box's columns."""
    out = np.empty((len(u_free), d))
    free = [i for i in range(d) if i not in fixed]
    out[:, free] = u_free
    for i, value in fixed.items():
        out[:, i] = value
    return out


def _near(
    axes: tuple[SearchAxis, ...],
    u: np.ndarray,
    e: np.ndarray,
    kinds: np.ndarray,
    share: int,
    rng: np.random.Generator,
) -> tuple[np.ndarray, np.ndarray]:
    """A scatter within _NEAR_CELLS cells (every continuous axis) of the best distinct starts, ``share``
    points in all: an error that peaks narrowly sits among cells that err already, which a start on a node
    or an edge, or a random one, may only graze."""
    best = _distinct(axes, u, np.argsort(-e, kind="stable"), _NEAR_PLACES)
    per = share // max(len(best), 1)
    width = np.array([0.0 if a.discrete else _NEAR_CELLS * a.cell_width for a in axes])
    points = [np.clip(u[i] + rng.uniform(-1.0, 1.0, (per, len(axes))) * width, 0.0, 1.0) for i in best]
    labels = [f"near {kinds[i]}" for i in best for _ in range(per)]
    return (np.vstack(points) if points else np.zeros((0, len(axes)))), np.array(labels, dtype=object)


def _same_place(axes: Sequence[SearchAxis], a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether points ``b`` (n, d) lie within one cell of ``a`` (d,) on every axis (the same level on a
    discrete one)."""
    width = np.array([a_.cell_width if not a_.discrete else 1e-9 for a_ in axes])
    return np.all(np.abs(b - a) <= width, axis=1)


def _distinct(axes: Sequence[SearchAxis], u: np.ndarray, order: Iterable[int], limit: int) -> np.ndarray:
    """The first ``limit`` indices of ``order`` (best first) that lie in different places."""
    kept: list[int] = []
    for i in order:
        if len(kept) == limit:
            break
        if not kept or not _same_place(axes, u[i], u[kept]).any():
            kept.append(i)
    return np.array(kept, dtype=int)


def _per_start(axes: Sequence[SearchAxis]) -> int:
    """Evaluations a start's compass search is expected to take."""
    return max(2 * sum(not a.discrete for a in axes) * _STEPS_PER_START, 1)


def _refine_in_batches(
    counter: _Counter, axes: tuple[SearchAxis, ...], starts: np.ndarray, values: np.ndarray, kinds: np.ndarray
) -> list[Candidate]:
    """Compass search from the starts, best first, in batches sized so a batch ends within the budget."""
    d_free = sum(not a.discrete for a in axes)
    per_start = _per_start(axes)
    found = [Candidate(float(v), u, str(k), float(v), 0) for u, v, k in zip(starts, values, kinds)]
    done = 0
    while done < len(starts) and counter.left >= 2 * d_free > 0:
        n = max(1, min(len(starts) - done, counter.left // per_start))
        batch = slice(done, done + n)
        u, e, steps = _compass(counter, axes, starts[batch], values[batch])
        for j, i in enumerate(range(done, done + n)):
            found[i] = Candidate(float(e[j]), u[j], str(kinds[i]), float(values[i]), int(steps[j]))
        done += n
    return found


def _compass(
    counter: _Counter, axes: tuple[SearchAxis, ...], u: np.ndarray, e: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compass search of every start at once: (u, e, improving steps) when every start's steps are below
    a ten-thousandth of a cell, or the budget is spent."""
    u, e = u.copy(), e.copy()
    free = np.array([i for i, a in enumerate(axes) if not a.discrete])
    width = np.array([a.cell_width for a in axes])
    step = np.tile(0.5 * width, (len(u), 1))
    steps = np.zeros(len(u), int)
    active = np.isfinite(e)  # an infinite error cannot improve
    directions = np.concatenate([np.eye(len(axes))[free], -np.eye(len(axes))[free]])
    while active.any():
        rows = np.flatnonzero(active)
        trial = np.clip(u[rows, None, :] + directions[None] * step[rows, None, :], 0.0, 1.0)
        flat = trial.reshape(-1, len(axes))
        if counter.left < len(flat):
            break
        values = counter(flat).reshape(len(rows), len(directions))
        best = np.argmax(values, axis=1)
        better = values[np.arange(len(rows)), best] > e[rows]
        moved = rows[better]
        u[moved] = trial[better, best[better]]
        e[moved] = values[better, best[better]]
        steps[moved] += 1
        stuck = rows[~better]
        step[stuck] *= 0.5
        active[stuck] = np.any(step[stuck][:, free] >= _FINAL_STEP_CELLS * width[free], axis=1)
        active &= np.isfinite(e)
    return u, e, steps


def _distinct_candidates(axes: Sequence[SearchAxis], found: list[Candidate], keep: int) -> list[Candidate]:

    order = sorted(range(len(found)), key=lambda i: -found[i].value)
    u = np.array([c.where for c in found])
    return [found[i] for i in _distinct(axes, u, order, keep)]
