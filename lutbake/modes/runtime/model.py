"""The runtime include's arithmetic in numpy float32, operation for operation (shaders/runtime.glsl.in).

What a GPU returns for ``lutbake_iridescence`` and ``lutbake_iridescence_rgb``, up to the GPU's own
rounding (fused multiply-adds, division and square root to a few ulp) and its bilinear filter's weight
precision (``filter_bits``: 8 on many GPUs; None, exact, is what SwiftShader does to ~1e-5). Tests compare
three.js with it (≤ 1e-4) and it with the ground truth; ``runtime_colour`` is also the ``lutbake-runtime``
row of the reports.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.modes.runtime.files import RuntimeTable, stored_table

if TYPE_CHECKING:
    from lutbake.physics.points import FilmPoints

__all__ = ["runtime_colour", "runtime_rgb"]

F = np.float32
_TWO_PI = F(6.283185307179586)


def _cis_m1(turns):
    """e^(2πi turns) − 1 as (re, im): the include's polynomials about the nearest quarter turn k, rotated by
    i^k = (ck, sk)."""
    k = np.floor(F(4) * turns + F(0.5))
    x = _TWO_PI * (turns - F(0.25) * k)
    x2 = x * x
    cm = x2 * (F(-0.5) + x2 * (F(1 / 24) + x2 * (F(-1 / 720) + x2 * F(1 / 40320))))
    s = x * (F(1) + x2 * (F(-1 / 6) + x2 * (F(1 / 120) + x2 * (F(-1 / 5040) + x2 * F(1 / 362880)))))
    half_k = np.floor(F(0.5) * k)
    odd = k - F(2) * half_k
    sign = F(1) - F(2) * (half_k - F(2) * np.floor(F(0.5) * half_k))
    ck, sk = (F(1) - odd) * sign, odd * sign
    return ck * cm + (ck - F(1)) - sk * s, sk * cm + sk + ck * s


def _sqrt(re, im):
    """Principal square root for im ≥ 0 (a step picks the larger part, as the include does)."""
    h = np.sqrt(np.maximum(F(0.5) * (np.hypot(re, im) + np.abs(re)), F(1e-30)))
    lo = F(0.5) * im / h
    t = (re >= 0).astype(F)
    return t * h + (F(1) - t) * lo, t * lo + (F(1) - t) * h


def _pol(y1, y2, p, q, em1, beta):
    """One polarization: (c0, f, w) as lutbake_rt_pol computes them (complex values as (re, im) pairs)."""
    inv = F(1) / (y1 + y2)
    a = (y1 - y2) * inv
    ea = F(4) * y1 * y2 * inv * inv
    pq = (p[0] + q[0], p[1] + q[1])
    n = F(1) / (pq[0] * pq[0] + pq[1] * pq[1])
    scale = F(2) * a * n
    at2 = (scale * (q[0] * pq[0] + q[1] * pq[1]), scale * (q[1] * pq[0] - q[0] * pq[1]))
    eb = np.maximum(F(4) * (p[0] * q[0] + p[1] * q[1]) * n, F(0))
    eq = ea / np.maximum(ea + a * a * eb, F(1e-30))
    c0 = a * a + (F(1) - eb) * ea * eq
    ab = (a - at2[0], -at2[1])
    zeta = (F(2) * y1 * inv - at2[0] + (ab[0] * em1[0] - ab[1] * em1[1]), -at2[1] + (ab[0] * em1[1] + ab[1] * em1[0]))
    kr = eb * eq
    kz = kr / np.maximum(zeta[0] * zeta[0] + zeta[1] * zeta[1], F(1e-30))
    f = (kr - kz * zeta[0], kz * zeta[1])
    num = (beta - zeta[0], -zeta[1])
    den = (beta + (F(1) - beta) * zeta[0], (F(1) - beta) * zeta[1])
    dd = np.maximum(den[0] * den[0] + den[1] * den[1], F(1e-30))
    w = (
        np.clip((num[0] * den[0] + num[1] * den[1]) / dd, F(-1), F(1)),
        np.clip((num[1] * den[0] - num[0] * den[1]) / dd, F(-1), F(1)),
    )
    return c0, f, w


def _film(meta, cos_theta, thickness_nm, eta1, eta2):
    t = meta["table"]
    c1 = np.clip(cos_theta, F(0), F(1))
    e1c = eta1 * c1
    g2 = np.sqrt(np.maximum((eta2 - eta1) * (eta2 + eta1) + e1c * e1c, F(1e-30)))
    x = F(2) * thickness_nm * g2
    turns = F(t["nu0_per_nm"]) * x
    em1 = _cis_m1(turns - np.floor(turns))
    beta = F(2) * x / (F(2) * x + F(t["zoom_nm"]))
    last = F(t["slices"] - 1)
    s = np.sqrt(np.minimum(x / F(t["x_max_nm"]), F(1))) * last
    j = np.minimum(np.floor(s), last - F(1))
    tiles = F(t["tiles_per_row"])
    row = np.floor(j / tiles)
    centre = ((j - row * tiles + F(0.5)) * F(t["nodes"]), (row + F(0.5)) * F(t["nodes"]))  # texels
    return {"c1": c1, "g2": g2, "em1": em1, "beta": beta, "xt": s - j, "centre": centre}


def _base(film, eta1, eta2, eta3, kappa3):
    """((c0_s + c0_p)/2, (f, w) for s, (f, w) for p) over one base index per point."""
    e1c = eta1 * film["c1"]
    ek = F(2) * eta3 * kappa3
    g3 = _sqrt((eta3 - eta1) * (eta3 + eta1) - kappa3 * kappa3 + e1c * e1c, ek)
    e22 = eta2 * eta2
    g2 = film["g2"]
    c0s, fs, ws = _pol(e1c, g2, (g2, F(0) * g2), g3, film["em1"], film["beta"])
    n3 = ((eta3 - kappa3) * (eta3 + kappa3), ek)
    c0p, fp, wp = _pol(
        e22 * film["c1"], eta1 * g2, (g2 * n3[0], g2 * n3[1]), (e22 * g3[0], e22 * g3[1]), film["em1"], film["beta"]
    )
    return F(0.5) * (c0s + c0p), (fs, ws), (fp, wp)


def _bilinear(image, x, y, bits):
    """A bilinear read at texel-space (x, y) (scanlines from the top; texel centres at +0.5), (n, 4);
    with ``bits``, the weights are rounded to that many bits as a texture unit does."""
    h, w, _ = image.shape
    fx, fy = x - F(0.5), y - F(0.5)
    x0 = np.clip(np.floor(fx), 0, w - 1).astype(np.int64)
    y0 = np.clip(np.floor(fy), 0, h - 1).astype(np.int64)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    tx, ty = (np.clip(fx - x0, 0, 1), np.clip(fy - y0, 0, 1))
    if bits:
        scale = F(2**bits)
        tx, ty = np.round(tx * scale) / scale, np.round(ty * scale) / scale
    tx, ty = tx[:, None], ty[:, None]
    top = image[y0, x0] * (F(1) - tx) + image[y0, x1] * tx
    bottom = image[y1, x0] * (F(1) - tx) + image[y1, x1] * tx
    return top * (F(1) - ty) + bottom * ty


def _read(
    table: RuntimeTable, film: dict, w: tuple[np.ndarray, np.ndarray], band: npt.ArrayLike, bits: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """V (re, im) of channel band ``band`` (an array or int) at table coordinate w, between the pair's slices."""
    t = table.meta["table"]
    half = F(0.5 * (t["nodes"] - 1))
    x = film["centre"][0] + w[0] * half
    y = film["centre"][1] + w[1] * half + np.asarray(band, F) * F(t["band_rows"] * t["nodes"])
    v = _bilinear(table.image, x, y, bits)
    xt = film["xt"]
    return v[:, 0] + (v[:, 2] - v[:, 0]) * xt, v[:, 1] + (v[:, 3] - v[:, 1]) * xt


def runtime_colour(
    table: RuntimeTable,
    cos_theta: npt.ArrayLike,
    thickness_nm: npt.ArrayLike,
    eta1: npt.ArrayLike,
    eta2: npt.ArrayLike,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
    filter_bits: int | None = None,
) -> np.ndarray:
    """Linear RGB (n, 3) as the include computes it. η3, κ3 of shape (n,) call ``lutbake_iridescence``,
    (n, 3) ``lutbake_iridescence_rgb``; everything is rounded to float32 first, as a GPU receives it."""
    cos_theta = np.atleast_1d(np.asarray(cos_theta, F))
    n = cos_theta.size
    args = [np.broadcast_to(np.asarray(v, F), (n,)) for v in (thickness_nm, eta1, eta2)]
    eta3, kappa3 = (np.asarray(v, F) for v in (eta3, kappa3))
    per_channel = eta3.ndim == 2
    film = _film(table.meta, cos_theta, *args)
    white = np.asarray(table.meta["table"]["white"], F)
    colour = np.empty((n, 3), F)
    bases = (
        [(eta3[:, c], kappa3[:, c]) for c in range(3)]
        if per_channel
        else [(np.broadcast_to(eta3, (n,)), np.broadcast_to(kappa3, (n,)))]
    )
    for c, (e3, k3) in enumerate(bases):
        c0, (fs, ws), (fp, wp) = _base(film, args[1], args[2], e3, k3)
        for band in [c] if per_channel else range(3):
            vs, vp = _read(table, film, ws, band, filter_bits), _read(table, film, wp, band, filter_bits)
            colour[:, band] = (
                (c0 + fs[0] + fp[0]) * white[band] + fs[0] * vs[0] - fs[1] * vs[1] + fp[0] * vp[0] - fp[1] * vp[1]
            )
    return colour.astype(float)


def runtime_rgb(stack: FilmPoints, space: str = "rec709", observer: str = "cie1931") -> np.ndarray:
    """The runtime path (the default table) at film stacks of constant indices: what `report` and `sweep`
    score beside a LUT (approximations.APPROXIMATIONS)."""
    stack.require("runtime table", film=None, base=None)
    cos_theta, thickness, eta1, eta2, eta3, kappa3 = (
        np.ravel(a)
        for a in np.broadcast_arrays(
            stack.cos_theta, stack.thickness_nm, stack.eta1, stack.eta2, stack.eta3, stack.kappa3
        )
    )
    return runtime_colour(stored_table(observer, space), cos_theta, thickness, eta1, eta2, eta3, kappa3)
