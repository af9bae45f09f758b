"""What both integrators share: a band of image rows being baked (``PendingRows``), the corner zoom's
total-reflection texels (``with_grazing_white``), a whole image band by band (``bake_rows_all``), and
stacks integrated at their texels' rule nodes (``colours_by_level``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import subset

if TYPE_CHECKING:
    from typing import TypeAlias

    import pyopencl

    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.numpy_path import NumpyBackend
    from lutbake.integrate.opencl import OpenCLBackend

    # The bake's integrators: each bakes rows and evaluates points of a spec (lutbake/integrate/opencl.py).
    Integrator: TypeAlias = OpenCLBackend | NumpyBackend

__all__ = ["PendingRows", "with_grazing_white", "bake_rows_all", "colours_by_level"]


class PendingRows:
    """A band being baked: ``result()`` waits for it and returns it (rows, width, 3) in float64."""

    def __init__(
        self,
        rows: np.ndarray,
        event: pyopencl.Event | None = None,
        keep: Sequence[object] = (),
        finish: Callable[[np.ndarray], np.ndarray] = lambda rows: rows,
    ):
        self._rows, self._event, self._keep, self._finish = rows, event, keep, finish

    def result(self) -> np.ndarray:
        if self._event is not None:
            self._event.wait()
            for item in self._keep:  # (count, event, planned): a pass's count of texels against the plan's
                if isinstance(item, tuple) and (item[1].wait() or item[0][0] != item[2]):
                    raise RuntimeError(f"a band's pass left {item[0][0]} texels where the plan counted {item[2]}")
            self._event, self._keep = None, ()
            self._rows = self._finish(self._rows)
        return self._rows.astype(np.float64, copy=False)


def with_grazing_white(spec: BakeSpec, y0: int, rows: np.ndarray) -> np.ndarray:
    """``rows`` (from image row y0) with the corner zoom's total-reflection texels set to exactly 1
    (plan.BakeSpec.grazing_white: the limit there, which no finite cos θ1 evaluates)."""
    rows[spec.grazing_white(y0, y0 + rows.shape[0])] = 1.0
    return rows


def bake_rows_all(integrator: Integrator, spec: BakeSpec) -> np.ndarray:
    """The whole packed image (height, width, 3) of ``spec`` in float64, band by band."""
    return np.concatenate([integrator.bake_rows(spec, y0, y1) for y0, y1 in spec.row_chunks()])


def colours_by_level(
    spec: BakeSpec,
    stack: FilmPoints,
    reflectance: Callable[[FilmPoints, np.ndarray], np.ndarray],
    pairs_per_call: int | None = None,
) -> np.ndarray:
    """RGB (P, 3) of P stacks of the spec's film (flat fields), each by its texel's spectral rule:
    ``reflectance(stacks, wavelength_nm)`` (R, (stacks, nodes)) summed with the rule's weights, level by
    level, at most ``pairs_per_call`` (stack, node) pairs per call (None: a level's stacks at once)."""
    stack.require("spec", film=None, base=None, eta1=spec.eta1, eta2=spec.eta2)
    levels = spec.cell_levels(stack.cos_theta, stack.opd_nm, stack.eta3, stack.kappa3)
    out = np.empty((levels.size, 3))
    for level in np.unique(levels):
        rule = spec.ladder.rule(level)
        cells = np.flatnonzero(levels == level)
        step = cells.size if pairs_per_call is None else max(1, pairs_per_call // rule.count)
        for start in range(0, cells.size, step):
            i = cells[start : start + step]
            out[i] = reflectance(subset(stack, i).as_column(), rule.wavelength_nm) @ rule.weights.T
    return out
