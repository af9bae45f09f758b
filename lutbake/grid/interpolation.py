"""How a LUT is read between its nodes (docs/lut-format.md, "Interpolation").

A LUT's header names one of two rules; the sampler (``sample.Lut``) and the
shader includes (shaders/lutbake.*.in) both follow it, on the same texels:

- ``linear``: multilinear in each axis's own coordinate, 4 bilinear fetches.
- ``cubic``: Catmull-Rom in each axis's own coordinate, 4 taps per axis, so
  4⁴ = 256 texel reads (no hardware filtering, so no 8-bit weight rounding),
  the sum clamped per channel to the range of those 256 texels. Its error falls
  as h⁴ where linear's falls as h², which is what buys the default LUTs their
  accuracy at the same bytes (docs/accuracy.md). The clamp is the standard
  remedy for Catmull-Rom's overshoot (its outer weights are negative): where the
  content turns within a cell, e.g. from R = 1 at cos θ1 = 0 to R = 0 one node
  later over a base that matches the ambient, the unclamped sum left the
  texels' range (−0.074 where every texel is ≥ 0); the clamped one never does,
  so a read is never negative where the texels are not. The range is that of
  every texel read, whatever its weight: it then changes only where the taps do
  (between cells), not where a weight reaches 0 (at every node: a range over
  the non-zero weights jumped by 2e-4 between f = N − 1 and N − 1 − 1e-5, which
  float32 on a GPU and float64 here round apart).

At the ends of an axis the missing tap is a ghost node folded onto real nodes:
the mirror image f(−s) = f(s) at the low end of a √- or ¼-power-spaced axis
that starts at 0 (the content is a function of the value v = s² or s⁴, hence
even in s), and
quadratic extrapolation f(−1) = 3f(0) − 3f(1) + f(2) elsewhere. Both keep
the rule exact for quadratics in the node coordinate (where the clamp does not
act: between texels that bracket them), and with fewer than
4 taps' worth of nodes the same folding still applies (an axis of 2 nodes
reads linearly). This module is the one Python statement of the weights
(``Lut._cubic`` sums and clamps); the includes write the same lines and the
tests hold them to ``Lut.sample``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cubic_taps", "mirrors_low_end"]

_EVEN_SPACINGS = ("sqrt", "root4")  # value = lo + c·s² or lo + c·s⁴: even in the node coordinate s


def mirrors_low_end(spacing: str, lo: float, zoomed: bool = False) -> bool:
    """Whether an axis's ghost node below node 0 is the mirror of node 1 (else extrapolated). In a LUT that
    zooms into the grazing corner (``zoomed``) no axis mirrors: at a fixed node coordinate the values move
    as √cos θ1 there, so the content is not even in √ of any axis's value."""
    return spacing in _EVEN_SPACINGS and lo == 0.0 and not zoomed


def cubic_taps(f: np.ndarray, count: int, mirror_low: bool) -> tuple[np.ndarray, np.ndarray]:
    """First node and (…, 4) Catmull-Rom weights at node coordinates ``f`` in [0, N − 1].

    The taps are nodes first … first + 3, clamped to [0, N − 1] (a clamped
    tap always has weight 0). ``mirror_low``: the axis is √-spaced from 0,
    so the ghost below node 0 mirrors node 1.
    """
    lower = np.clip(np.floor(f), 0, count - 2)
    t = f - lower
    if count == 2:  # one cell: linear, on taps −1 … 2
        return (lower - 1).astype(np.int64), np.stack([0.0 * t, 1.0 - t, t, 0.0 * t], axis=-1)
    t2, t3 = t * t, t * t * t
    below = (-t3 + 2.0 * t2 - t) / 2.0  # node lower − 1
    w0 = (3.0 * t3 - 5.0 * t2 + 2.0) / 2.0  # node lower
    w1 = (-3.0 * t3 + 4.0 * t2 + t) / 2.0  # node lower + 1
    above = (t3 - t2) / 2.0  # node lower + 2
    at_low, at_high = lower == 0, lower == count - 2
    if mirror_low:
        low = np.stack([w0, w1 + below, above, 0.0 * t], axis=-1)
    else:
        low = np.stack([w0 + 3.0 * below, w1 - 3.0 * below, above + below, 0.0 * t], axis=-1)
    high = np.stack([0.0 * t, below + above, w0 - 3.0 * above, w1 + 3.0 * above], axis=-1)
    inner = np.stack([below, w0, w1, above], axis=-1)
    w = np.where(at_low[..., None], low, np.where(at_high[..., None], high, inner))
    first = np.where(at_low, 0, np.where(at_high, count - 4, lower - 1)).astype(np.int64)
    return first, w
