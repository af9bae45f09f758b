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


def _cis_m1_conj(turns):
    """conj(e^(2πi turns) − 1) as (re, im): with t = turns − round(turns), (−2s², −2sc), s = sin πt and c = cos πt
    by the include's near-minimax polynomials in t²."""
    t = turns - np.floor(turns + F(0.5))
    u = t * t
    s2 = t * (F(-6.28317941) + u * (F(10.3347356) + u * (F(-5.08720983) + u * F(1.11679188))))
    c = F(0.999999953) + u * (F(-4.93479286) + u * (F(4.05841191) + u * (F(-1.33188014) + u * F(0.219696764))))
    return F(-0.5) * s2 * s2, s2 * c


def _sqrt(re, im):
    """Principal square root for im ≥ 0 (a select picks the larger part, as the include does)."""
    h = np.sqrt(np.maximum(F(0.5) * (np.hypot(re, im) + np.abs(re)), F(1e-30)))
    lo = F(0.5) * im / h
    right = re >= 0
    return np.where(right, h, lo), np.where(right, lo, h)


def _face(y1, y2):
    """Interface 1-2 of one polarization: (a, −a/2, 1 + a, 1 − a², a²) as lutbake_rt_face computes them."""
    i2 = F(2) / (y1 + y2)
    u1 = y1 * i2
    a = u1 - F(1)
    return {"a": a, "na": F(-0.5) * a, "u1": u1, "ea": u1 * (y2 * i2), "a2": a * a}


def _pol(face, p, q, pq, film):
    """One polarization: (c0, the read's weights (4 columns), Re of its white share, w in texels) as lutbake_rt_pol
    computes them, from conj(ζ) (complex values as (re, im) pairs)."""
    n4 = F(4) / (pq[0] * pq[0] + pq[1] * pq[1])
    scale = face["na"] * n4
    nat2 = (scale * (q[0] * pq[0] + q[1] * pq[1]), scale * (q[0] * pq[1] - q[1] * pq[0]))
    eb = np.maximum((p[0] * q[0] + p[1] * q[1]) * n4, F(0))
    eq = face["ea"] / np.maximum(face["ea"] + face["a2"] * eb, F(1e-30))
    kr = eb * eq
    c0 = face["a2"] + face["ea"] * (eq - kr)
    ab, em = (face["a"] + nat2[0], nat2[1]), film["em1c"]
    zc = (face["u1"] + nat2[0] + (ab[0] * em[0] - ab[1] * em[1]), nat2[1] + (ab[0] * em[1] + ab[1] * em[0]))
    kz = kr / np.maximum(zc[0] * zc[0] + zc[1] * zc[1], F(1e-30))
    g = (kr - kz * zc[0], kz * zc[1])
    g1 = (g[0] * film["xt"], g[1] * film["xt"])
    weights = np.stack([g[0] - g1[0], g[1] - g1[1], g1[0], g1[1]], axis=1)
    den = (film["beta"] + film["alpha"] * zc[0], film["alpha"] * zc[1])
    mob = ((film["beta"] - zc[0]) * den[0] - zc[1] * den[1], film["mob_im"] * zc[1])
    r = film["half"] / np.maximum(den[0] * den[0] + den[1] * den[1], F(1e-30))
    w = (np.clip(mob[0] * r, -film["half"], film["half"]), np.clip(mob[1] * r, -film["half"], film["half"]))
    return c0, weights, g[0], w


def _film(meta, cos_theta, thickness_nm, eta1, eta2):
    t = meta["table"]
    c1 = np.clip(cos_theta, F(0), F(1))
    e1c = eta1 * c1
    g2 = np.sqrt(np.maximum((eta2 - eta1) * (eta2 + eta1) + e1c * e1c, F(1e-30)))
    h = g2 / (eta2 * eta2)
    xh = thickness_nm * g2
    quarter_zoom = F(0.25 * t["zoom_nm"])
    inv = F(1) / (xh + quarter_zoom)
    beta = xh * inv
    last = F(t["slices"] - 1)
    s = np.minimum(np.sqrt(xh * F(2 * float(last) ** 2 / t["x_max_nm"])), last - F(1 / 4096))
    j = np.floor(s)
    tile = (j + F(0.5)) * F(1 / t["tiles_per_row"])
    nodes = F(t["nodes"])
    centre = ((tile - np.floor(tile)) * F(t["tiles_per_row"] * t["nodes"]), np.floor(tile) * nodes + F(0.5) * nodes)
    return {
        "e1c": e1c,
        "g2": g2,
        "h": h,
        "face_s": _face(e1c, g2),
        "face_p": _face(c1, eta1 * h),
        "em1c": _cis_m1_conj(xh * F(2 * t["nu0_per_nm"])),
        "beta": beta,
        "alpha": quarter_zoom * inv,
        "mob_im": beta * (F(2) - beta),
        "half": F(0.5 * (t["nodes"] - 1)),
        "xt": s - j,
        "centre": centre,  # texels
    }


def _base(film, eta1, eta2, eta3, kappa3):
    """Both polarizations' (c0, weights, white share, w) over one base index per point."""
    ek = F(2) * eta3 * kappa3
    g3 = _sqrt((eta3 - eta1) * (eta3 + eta1) - kappa3 * kappa3 + film["e1c"] * film["e1c"], ek)
    g2 = film["g2"]
    s = _pol(film["face_s"], (g2, F(0) * g2), g3, (g2 + g3[0], g3[1]), film)
    pn = (film["h"] * ((eta3 - kappa3) * (eta3 + kappa3)), film["h"] * ek)
    p = _pol(film["face_p"], pn, g3, (pn[0] + g3[0], pn[1] + g3[1]), film)
    return s, p


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


def _read(table: RuntimeTable, film: dict, pol: tuple, band: npt.ArrayLike, bits: int | None) -> np.ndarray:
    """One polarization's read of channel band ``band`` (an array or int) at its w, weighted: Re(K e^(iθ) V / ζ)."""
    t = table.meta["table"]
    w = pol[3]
    x = film["centre"][0] + w[0]
    y = film["centre"][1] + w[1] + np.asarray(band, F) * F(t["band_rows"] * t["nodes"])
    return (_bilinear(table.image, x, y, bits) * pol[1]).sum(axis=1)


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
        s, p = _base(film, args[1], args[2], e3, k3)
        share = F(0.5) * (s[0] + p[0]) + s[2] + p[2]
        for band in [c] if per_channel else range(3):
            departure = _read(table, film, s, band, filter_bits) + _read(table, film, p, band, filter_bits)
            colour[:, band] = share * white[band] + departure
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
