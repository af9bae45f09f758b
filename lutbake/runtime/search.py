"""A searched maximum of an error over a box: corners, edges, random starts, then local refinement.

The error is a vectorized function of points in the unit cube [0, 1]^d ((n, d) → (n,)), so the caller
maps node coordinates to its domain. The search evaluates every corner, points along every edge, a
seeded random sample, then refines the worst few by a compass (pattern) search with shrinking steps,
clipped to the cube. Written to move into a shared worst-case module (lutbake/worstcase.py) unchanged.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["SearchResult", "search_maximum"]


@dataclass
class SearchResult:
    """The worst point found (unit-cube coordinates), its error, and every point evaluated."""

    worst: np.ndarray       # (d,)
    value: float
    points: np.ndarray      # (n, d) every evaluated point
    values: np.ndarray      # (n,)

    @property
    def evaluations(self) -> int:
        return self.values.size


def _edges(d: int, per_edge: int) -> np.ndarray:
    """``per_edge`` interior points on each of the d·2^(d−1) edges of the cube."""
    t = (np.arange(1, per_edge + 1) / (per_edge + 1))
    out = []
    for axis in range(d):
        for corner in itertools.product((0.0, 1.0), repeat=d - 1):
            base = np.insert(np.array(corner), axis, 0.0)
            pts = np.tile(base, (per_edge, 1))
            pts[:, axis] = t
            out.append(pts)
    return np.vstack(out)


def search_maximum(error, d: int, *, random: int = 512, per_edge: int = 3, refine: int = 8,
                   steps=(0.1, 0.03, 0.01, 0.003, 0.001), seed: int = 0, starts=None) -> SearchResult:
    """Largest ``error`` found over [0, 1]^d.

    Starting points: the 2^d corners, ``per_edge`` points on every edge, ``random`` seeded uniform points
    and the caller's ``starts`` (n, d) (a stress grid, say). The ``refine`` worst are improved by a
    compass search: at each step size s, move to the best of the 2d neighbours x ± s·e_i while that
    improves, then shrink s.
    """
    rng = np.random.default_rng(seed)
    start = np.vstack([np.array(list(itertools.product((0.0, 1.0), repeat=d))), _edges(d, per_edge),
                       rng.random((random, d))] + ([] if starts is None else [np.asarray(starts, float)]))
    seen_points, seen_values = [start], [error(start)]
    values = seen_values[0]
    order = np.argsort(values)[::-1]
    best = start[order[:refine]].copy()
    best_value = values[order[:refine]].copy()
    directions = np.vstack([np.eye(d), -np.eye(d)])
    for step in steps:
        for _ in range(20):   # moves at this step size (each one improves, so this rarely binds)
            trial = np.clip(best[:, None, :] + step * directions[None], 0.0, 1.0).reshape(-1, d)
            trial_values = error(trial)
            seen_points.append(trial)
            seen_values.append(trial_values)
            trial_values = trial_values.reshape(len(best), 2 * d)
            pick = np.argmax(trial_values, axis=1)
            better = trial_values[np.arange(len(best)), pick] > best_value
            if not better.any():
                break
            best[better] = trial.reshape(len(best), 2 * d, d)[better, pick[better]]
            best_value[better] = trial_values[better, pick[better]]
    points, values = np.vstack(seen_points), np.concatenate(seen_values)
    i = int(np.nanargmax(values))
    return SearchResult(points[i], float(values[i]), points, values)
