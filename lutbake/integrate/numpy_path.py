"""The numpy integrator: optics.film_reflectance (the ground truth's float64 physics) at each texel's
spectral rule nodes. The reference for the kernels in tests and their self-check, and the fallback where
no OpenCL device runs them."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from lutbake.integrate.bands import PendingRows, colours_by_level, with_grazing_white
from lutbake.integrate.series import SeriesStats
from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec

__all__ = ["NumpyBackend"]


class NumpyBackend:
    """float64 numpy evaluation of the exact Airy reflectance at each texel's rule nodes."""

    name = "numpy"
    device = "numpy / float64 (host CPU)"
    _CELLS_X_NODES = 1 << 19  # (cell, node) pairs per optics call: ~310 bytes each (plan.MEMORY)

    def bake_rows(self, spec: BakeSpec, y0: int, y1: int) -> np.ndarray:
        stacks = spec.texel_stacks(a.ravel() for a in spec.cell_params(y0, y1))
        return with_grazing_white(spec, y0, self.evaluate(spec, stacks).reshape(y1 - y0, -1, 3))

    def begin_rows(self, spec: BakeSpec, y0: int, y1: int) -> PendingRows:
        return PendingRows(self.bake_rows(spec, y0, y1))

    @staticmethod
    def series_plan(spec: BakeSpec) -> SeriesStats:
        """This path integrates every texel directly."""
        return SeriesStats((0, 0, spec.cells))

    def evaluate(self, spec: BakeSpec, stack: FilmPoints) -> np.ndarray:
        """RGB (P, 3) of P stacks of the spec's film (flat fields), each at its texel's rule nodes."""
        return colours_by_level(spec, stack, lambda s, nm: film_reflectance(s, nm)[2], self._CELLS_X_NODES)
