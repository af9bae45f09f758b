"""Where a bake's texels are: the node values of a BakeSpec's grid and the bands of image rows it bakes.

The η3 axis's admittance spacings and the corner zoom follow the incidence, so the nodes of D, η3 and
κ3 are given per cos θ1 node (``node_values``), and η3 per image column (``eta3_columns``). Under a
corner zoom the node cos θ1 = 0 holds the limit along each node's curve, evaluated at CORNER_COS, and
its nodes past the zoom's share hold total reflection (``grazing_white``). A bake works in bands of whole
image rows (``BakeSpec.row_chunks``), so a grid of any size bakes and streams in bounded memory;
``cell_params`` gives a band's texels' (cos θ1, D, η3, κ3). BakeSpec's methods of the same names call
these functions on the spec.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lutbake.grid.axis import Axis
    from lutbake.grid.spec import BakeSpec

__all__ = ["CORNER_COS", "node_values", "eta3_columns", "grazing_white", "cell_params"]

CORNER_COS = 1e-5  # where a corner LUT evaluates its cos θ1 = 0 nodes: the limit along each node's curve


def cos_evaluated(spec: BakeSpec) -> np.ndarray:
    """cos θ1 at which each cos θ1 node's texels are evaluated: the node's own value, except that under a
    corner zoom the node cos θ1 = 0 holds the limit along each node's curve, reached at CORNER_COS (the
    colour there is a function of the corner's ratios, to O(cos θ1))."""
    cos_t = spec.axis["cos_theta"].values()
    if spec.has_corner:
        cos_t[cos_t == 0.0] = CORNER_COS
    return cos_t


def node_values(spec: BakeSpec, name: str) -> np.ndarray:
    """Node values of axis ``name``: cos θ1 (N_cos,) as evaluated; D, η3, κ3 (N, N_cos), one column per
    cos θ1 node, since the admittance spacings and the corner zoom follow the incidence."""
    cos_t = cos_evaluated(spec)
    if name == "cos_theta":
        return cos_t
    axis = spec.axis[name]
    v = np.array(np.broadcast_to(axis.values(cos_t, spec.eta1), (axis.count, cos_t.size)))
    if axis.corner:  # a zoom's cos θ1 axis starts at 0 (validated): its first column is the limit
        v[:, 0] = _grazing_column(axis, axis.corner[0], spec.eta1)
    return v


def _grazing_column(axis: Axis, corner_nodes: int, eta1: float) -> np.ndarray:
    """Node values of a corner axis in the cos θ1 = 0 column, evaluated at CORNER_COS: there the zoom is
    H(ρ)/H(ρ_max) → H(ρ), so node u < β holds the ratio ρ = (1 − h)^−4 − 1, h = node index/``corner_nodes``,
    set exactly (the bisection would reach it only to O(√CORNER_COS)); nodes u ≥ β hold total reflection
    (``grazing_white``) and keep the value the bisection gives."""
    h = np.minimum(np.arange(axis.count) / corner_nodes, 1.0)
    with np.errstate(divide="ignore"):
        rho = (1.0 - h) ** -4.0 - 1.0
    return np.where(h < 1.0, axis.value_at_ratio(rho, CORNER_COS, eta1), axis.values(CORNER_COS, eta1))


def eta3_columns(spec: BakeSpec) -> np.ndarray:
    """η3 of each image column, in column order (layout.TileLayout: η3 nodes at the column's cos θ1 node)."""
    return np.ascontiguousarray(node_values(spec, "eta3")).ravel()


def _band_nodes(spec: BakeSpec, y0: int, y1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(i_cos, i_opd, i_eta3, i_kappa3) of every texel in rows [y0, y1), broadcast to (rows, width)."""
    width, _ = spec.image_size
    return spec.layout.nodes(np.arange(width)[None, :], np.arange(y0, y1)[:, None])


def grazing_white(spec: BakeSpec, y0: int, y1: int) -> np.ndarray:
    """Texels of rows [y0, y1) that hold total reflection, (rows, width) bool: in the cos θ1 = 0 column of a
    corner zoom, every node at or past the zoom's share on some axis (ρ → ∞ along its curve, so R → 1,
    as the ground truth has it at cos θ1 = 0). The integrators set them to exactly 1."""
    width, _ = spec.image_size
    i_cos, i_opd, i_eta3, i_kappa3 = _band_nodes(spec, y0, y1)
    white = np.zeros((y1 - y0, width), bool)
    for axis, index in zip(spec.axes[1:], (i_opd, i_eta3, i_kappa3)):
        if axis.corner:
            white |= index >= axis.corner[0]
    return white & (i_cos == 0)


def cell_params(spec: BakeSpec, y0: int, y1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(cos θ1, D, η3, κ3) of every texel in rows [y0, y1), each (y1 − y0, width)."""
    width, _ = spec.image_size
    i_cos, i_opd, _, i_kappa3 = _band_nodes(spec, y0, y1)
    shape = (y1 - y0, width)
    cos_t, opd, kappa3 = (node_values(spec, n) for n in ("cos_theta", "opd_nm", "kappa3"))
    return (
        np.broadcast_to(cos_t[i_cos], shape),
        np.broadcast_to(opd[i_opd, i_cos], shape),
        np.broadcast_to(eta3_columns(spec), shape),
        np.broadcast_to(kappa3[i_kappa3, i_cos], shape),
    )
