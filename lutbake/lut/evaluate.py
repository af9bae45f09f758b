"""Film points evaluated as `lutbake eval` does: the converged ground truth, the bake's integrator (--fast),
or the reflectances at one wavelength.

The ground truth is lutbake/spectral/reference.py's converged integral; the fast path runs the bake's
integrator on constant-index points (lutbake/integrate/batch.py) on the OpenCL device asked for, and
returns the a-priori truncation bound of the points past the spectral rule's node cap, so the caller can
warn above ``CAPPED_WARNING_RGB``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from lutbake.integrate.batch import fast_colours, truth_colours
from lutbake.io.progress import no_progress
from lutbake.physics.points import FilmPoints, check_value
from lutbake.spectral.reference import spectral_reflectance

if TYPE_CHECKING:
    from lutbake.integrate.bands import Integrator
    from lutbake.integrate.devices import DeviceChoice

__all__ = ["CAPPED_WARNING_RGB", "point_colours", "point_reflectances"]

CAPPED_WARNING_RGB = 1e-4  # |ΔRGB| past the spectral node cap above which an eval (its bound) or a bake warns


def point_colours(
    points: FilmPoints,
    observer: str = "cie1931",
    space: str = "rec709",
    fast: bool = False,
    backend: str = "auto",
    progress: Callable[[int, int, str], None] = no_progress,
    device: DeviceChoice = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(RGB, XYZ, bound) of ``points``, each RGB and XYZ (P, 3): the converged ground truth (bound None), or
    with ``fast`` the bake's integrator ('auto', 'opencl' or 'numpy' ``backend`` on OpenCL ``device``;
    constant indices only) and each point's truncation bound past the spectral node cap (0 below it).
    ``progress(done, total, note)`` as the points go.

    >>> points = FilmPoints.build(eta2=1.33, thickness_nm=300.0, cos_theta=1.0, eta3=1.5)
    >>> truth, _, _ = point_colours(points)
    >>> fast, _, bound = point_colours(points, fast=True, backend="numpy")
    >>> bool(abs(fast - truth).max() < 3e-6), bound.tolist()
    (True, [0.0])
    """
    if not fast:
        return (*truth_colours(points, observer, space, progress), None)
    if not (points.film or points.base):  # fast_colours refuses named materials before a backend is made
        from lutbake.integrate.opencl import backend as make_backend

        integrator: str | Integrator = make_backend(backend, device=device)
    else:
        integrator = backend
    return fast_colours(points, observer, space, integrator, progress)


def point_reflectances(points: FilmPoints, wavelength_nm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """(R_s, R_p, R) of ``points`` at one wavelength (nm; checked), each (P,), and the wavelength as checked.

    >>> rs, rp, r, at = point_reflectances(FilmPoints.build(eta2=1.5, opd_nm=0.0, cos_theta=1.0, eta3=1.5), 550)
    >>> round(float(r[0]), 6), at
    (0.04, 550.0)
    """
    lam = check_value("wavelength_nm", wavelength_nm)
    rs, rp, r = (v[:, 0] for v in spectral_reflectance(points, lam))
    return rs, rp, r, float(lam[0])
