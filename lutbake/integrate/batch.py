"""Batch evaluation of many points (`eval --points`): ground truth or the bake's integrator.

``truth_colours`` integrates RGB and XYZ in one pass of the ground truth
(lutbake/spectral/reference.py: one reflectance evaluation serves both projections, half the
work of two calls), in batches so progress can be reported. ``fast_colours``
runs the bake's integrator (OpenCL kernel or numpy, per-point spectral rule
from spectral.RuleLadder) on constant-index points grouped by (η1, η2): the
same arithmetic as a bake texel, ~10³× faster than the ground truth, and
held to it by tests (|ΔRGB| ≤ 3e-6 below the ladder's node cap; 2.1e-6 measured
at 10,000 random points). Points past
the cap get the a-priori truncation bound the bake records, returned so the
caller can warn.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.io.progress import no_progress
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour, subset

if TYPE_CHECKING:
    from collections.abc import Callable

    from lutbake.integrate.bands import Integrator
    from lutbake.physics.colorimetry import Colorimetry

__all__ = ["truth_colours", "fast_colours"]

_BATCH_POINTS = 2048
# Any valid grid: evaluate() reads the spec's film, colour settings and ladder, never its axes.
_ANY_AXES = (
    Axis("cos_theta", 0.0, 1.0, 2),
    Axis("opd_nm", 0.0, 1.0, 2),
    Axis("eta3", 1.0, 2.0, 2),
    Axis("kappa3", 0.0, 1.0, 2),
)


def _batches(n: int) -> list[tuple[int, int]]:
    return [(s, min(s + _BATCH_POINTS, n)) for s in range(0, n, _BATCH_POINTS)]


def truth_colours(
    points: FilmPoints, observer: str, space: str, progress: Callable[[int, int, str], None] = no_progress
) -> tuple[np.ndarray, np.ndarray]:
    """Converged (RGB, XYZ), each (P, 3), batch by batch with ``progress(rows done, rows)``."""
    n = len(points)
    out = np.empty((n, 6))
    progress(0, n, "ground truth")
    for start, stop in _batches(n):
        out[start:stop] = reference_colour(subset(points, slice(start, stop)), observer, space, "rgb+xyz").values
        progress(stop, n, "ground truth")
    return out[:, :3], out[:, 3:]


def fast_colours(
    points: FilmPoints,
    observer: str,
    space: str,
    backend: str | Integrator = "auto",
    progress: Callable[[int, int, str], None] = no_progress,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(RGB, XYZ, truncation bound) of constant-index points through the bake's integrator: ``backend``
    names one ('auto', 'opencl', 'numpy') or is one already made (integrate.backend)."""
    from lutbake.integrate.opencl import backend as make_backend
    from lutbake.physics.colorimetry import colorimetry

    if points.film or points.base:
        raise ParameterError(
            "{fast} takes constant indices ({eta2}, {eta3}, {kappa3}): named materials "
            "({film}, {base}) need the ground truth (omit {fast})"
        )
    integrator = make_backend(backend) if isinstance(backend, str) else backend
    n = len(points)
    rgb, bound = np.empty((n, 3)), np.zeros(n)
    films = np.stack([points.eta1, points.eta2], axis=1)
    progress(0, n, f"{integrator.name} integrator")
    done = 0
    for eta1, eta2 in np.unique(films, axis=0):
        spec = BakeSpec(eta2=float(eta2), eta1=float(eta1), axes=_ANY_AXES, space=space, observer=observer)
        rows = np.flatnonzero((films[:, 0] == eta1) & (films[:, 1] == eta2))
        for start, stop in _batches(rows.size):
            i = rows[start:stop]
            batch = subset(points, i)
            rgb[i] = integrator.evaluate(spec, batch)
            bound[i] = spec.truncation_estimate(batch.cos_theta, batch.opd_nm, batch.eta3, batch.kappa3)
            done += i.size
            progress(done, n, f"{integrator.name} integrator")
    return rgb, rgb @ _rgb_to_xyz_matrix(colorimetry(observer, space)), bound


def _rgb_to_xyz_matrix(cm: Colorimetry) -> np.ndarray:
    """M with XYZ = RGB @ M for the integrated tables: each RGB channel is rescaled to make
    a flat reflector white (lutbake/physics/colorimetry.py), so the space's own matrix is off by ~1e-4."""
    return np.linalg.lstsq(cm.rgb_table.T, cm.xyz_table.T, rcond=None)[0]
