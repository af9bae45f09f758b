"""The self-check a device passes before it bakes: the kernel's reflectance at stiff stacks, and a small
bake through the backend's integrator, against the numpy path (lutbake/integrate/numpy_path.py). Runtimes
have disagreed at such stacks (a compiler fusing into an fma what the kernel keeps apart): a device that
builds the kernel but fails here is not used (docs/devices.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lutbake.integrate.bands import bake_rows_all
from lutbake.integrate.numpy_path import NumpyBackend
from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints
from lutbake.spectral.fourier import series_colour

if TYPE_CHECKING:
    import pyopencl

    from lutbake.integrate.opencl import OpenCLBackend

__all__ = ["SELF_CHECK_TOLERANCE", "self_check_error", "checked_error"]

# Self-check stacks: stiff corners where runtimes have disagreed (grazing incidence over a
# base matching the ambient, thick films, metals, evanescent films), R compared with numpy.
_SELF_CHECK = np.array(
    [
        # cos θ1, D (nm), η3, κ3, λ (nm)
        [1e-6, 0.0, 1.0, 1e-12, 550.0],
        [1e-6, 1e-9, 1.0, 1e-12, 400.0],
        [0.0, 500.0, 1.5, 0.0, 500.0],
        [0.3, 1e5, 2.0, 3.0, 700.0],
        [1.0, 800.0, 1.0, 0.0, 450.0],
        [0.05, 4000.0, 0.2, 3.5, 610.0],
        [0.7, 250.0, 1.5, 1e-9, 380.0],
        [1e-12, 1e4, 3.0, 100.0, 820.0],
    ]
)
SELF_CHECK_TOLERANCE = {"float64": 1e-10, "float32": 2e-5}


def self_check_error(backend: OpenCLBackend) -> float:
    """Largest error of the kernel against numpy: R at the self-check stacks (films η2 1.5 under
    η1 1 and η2 1.2 under η1 1.6), and the baked RGB of a small grid through the backend's
    integrator (series or direct) against the numpy path's direct quadrature."""
    from lutbake.grid.spec import Axis, BakeSpec

    cos1, opd, eta3, kappa3, lam = _SELF_CHECK.T
    worst = 0.0
    for eta1, eta2 in ((1.0, 1.5), (1.6, 1.2)):
        stack = FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos1, opd_nm=opd, eta3=eta3, kappa3=kappa3)
        fast = backend.reflectance(stack, lam)
        ref = film_reflectance(stack, lam)[2]
        worst = max(worst, float(np.max(np.abs(fast - ref))))
    grid = BakeSpec(
        eta2=1.5,
        compute=backend.compute,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 4),
            Axis("opd_nm", 0.0, 2000.0, 4),
            Axis("eta3", 1.0, 3.0, 2),
            Axis("kappa3", 0.0, 4.0, 2),
        ),
    )
    expected = bake_rows_all(NumpyBackend(), grid)
    if getattr(backend, "integrator", "direct") == "series":
        stacks = grid.texel_stacks(np.ravel(p) for p in grid.cell_params(0, grid.image_size[1]))
        series = series_colour(stacks, grid.observer, grid.space).values
        assert series is not None  # integrate=True (the default) always fills it
        expected = np.where(np.isnan(series), expected.reshape(-1, 3), series).reshape(expected.shape)
    return max(worst, float(np.max(np.abs(bake_rows_all(backend, grid) - expected))))


_CHECKED: dict[tuple[int, str, str], float] = {}


def checked_error(backend: OpenCLBackend, device: pyopencl.Device) -> float:
    """``self_check_error`` once per device, compute precision and integrator per process."""
    key = (device.int_ptr, backend.compute, backend.integrator)
    if key not in _CHECKED:
        _CHECKED[key] = self_check_error(backend)
    return _CHECKED[key]
