"""Reference sampler: what a GPU returns when it samples a lutbake LUT.

It reads only the EXR (metadata from its header) and follows the shader
includes step by step: each axis value → its warp → a continuous node
coordinate clamped to [0, N − 1]; (cos θ, D) through hardware bilinear
filtering inside a tile (texel centres, clamp-to-edge addressing); the four
tiles around (η3, κ3) blended with manual lerps. ``filter_bits`` quantizes
the bilinear weights as fixed-function texture units do (8 bits on many
GPUs); None uses exact weights.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .lutfile import read_lut
from .plan import Axis

__all__ = ["Lut"]


@dataclass
class Lut:
    meta: dict
    image: np.ndarray  # (height, width, 3), as stored

    @classmethod
    def load(cls, path) -> "Lut":
        meta, image = read_lut(path)
        return cls(meta, image)

    @property
    def axes(self) -> list:
        return [Axis(a["name"], a["min"], a["max"], a["count"], a["spacing"]) for a in self.meta["axes"]]

    @property
    def eta1(self) -> float:
        return self.meta["constants"]["eta1"]

    @property
    def eta2(self) -> float:
        return self.meta["constants"]["eta2"]

    def in_domain(self, cos_theta, opd_nm, eta3, kappa3) -> np.ndarray:
        """True where every coordinate lies inside the LUT's axis ranges."""
        ok = True
        for axis, v in zip(self.axes, (cos_theta, opd_nm, eta3, kappa3)):
            v = np.asarray(v, float)
            ok = ok & (v >= axis.lo) & (v <= axis.hi)
        return np.asarray(ok)

    def node_coords(self, cos_theta, opd_nm, eta3, kappa3) -> list:
        """Continuous node coordinates in [0, N − 1] per axis (clamped, like the shaders)."""
        return [np.clip(axis.to_unit(v), 0.0, 1.0) * (axis.count - 1)
                for axis, v in zip(self.axes, np.broadcast_arrays(cos_theta, opd_nm, eta3, kappa3))]

    def sample(self, cos_theta, opd_nm, eta3, kappa3, filter_bits=None) -> np.ndarray:
        """Linear RGB (…, 3) at the given film parameters."""
        f_cos, f_opd, f_eta3, f_kappa3 = self.node_coords(cos_theta, opd_nm, eta3, kappa3)
        n_cos, n_opd, n_eta3, n_kappa3 = (a.count for a in self.axes)
        i_e, t_e = _lower_node(f_eta3, n_eta3)
        i_k, t_k = _lower_node(f_kappa3, n_kappa3)
        corners = {}
        for de in (0, 1):
            for dk in (0, 1):
                x = (i_e + de) * n_cos + f_cos
                y = (i_k + dk) * n_opd + f_opd
                corners[de, dk] = self._bilinear(x, y, filter_bits)
        lower = _lerp(corners[0, 0], corners[1, 0], t_e)
        upper = _lerp(corners[0, 1], corners[1, 1], t_e)
        return _lerp(lower, upper, t_k)

    def _bilinear(self, x, y, filter_bits):
        """Hardware bilinear at texel-space (x, y) measured between texel centres."""
        h, w, _ = self.image.shape
        x0, y0 = np.floor(x), np.floor(y)
        ax, ay = x - x0, y - y0
        if filter_bits:
            scale = float(1 << filter_bits)
            ax, ay = np.round(ax * scale) / scale, np.round(ay * scale) / scale
        x0, y0 = x0.astype(np.int64), y0.astype(np.int64)
        x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)

        def tap(y, x):  # gather first, widen only the taps (not the whole image)
            return self.image[y, x].astype(np.float64)

        top = _lerp(tap(y0, x0), tap(y0, x1), ax)
        bottom = _lerp(tap(y1, x0), tap(y1, x1), ax)
        return _lerp(top, bottom, ay)


def _lower_node(f, count):
    i = np.minimum(np.floor(f), count - 2).astype(np.int64)
    return i, f - i


def _lerp(a, b, t):
    t = np.asarray(t, float)[..., None]
    return a * (1.0 - t) + b * t
