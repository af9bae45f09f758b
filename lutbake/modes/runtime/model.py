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
SQRT2 = 1.41421356  # as the include writes it


def _cis_m1_conj(turns):
    """conj(e^(2πi turns) − 1) as (re, im): with t = turns − round(turns), (−2s², −2sc), s = sin πt and c = cos πt
    by the include's near-minimax polynomials in t²."""
    t = turns - np.floor(turns + F(0.5))
    u = t * t
    s2 = t * (F(-6.28317941) + u * (F(10.3347356) + u * (F(-5.08720983) + u * F(1.11679188))))
    c = F(0.999999953) + u * (F(-4.93479286) + u * (F(4.05841191) + u * (F(-1.33188014) + u * F(0.219696764))))
    return F(-0.5) * s2 * s2, s2 * c


def _sqrt2(re, im):
    """√2 times the principal square root for im ≥ 0 (a select picks the larger part, as the include does)."""
    h = np.sqrt(np.maximum(np.hypot(re, im) + np.abs(re), F(1e-30)))
    lo = im / h
    right = re >= 0
    return np.where(right, h, lo), np.where(right, lo, h)


def _face(y1, y2):
    """Interface 1-2 of one polarization: (a, −a/2, 1 + a, 1 − a², 1 − a² + 1e-30, a²) as lutbake_rt_face computes
    them."""
    i2 = F(2) / (y1 + y2)
    u1 = y1 * i2
    a = u1 - F(1)
    ea = u1 * (y2 * i2)
    return {"a": a, "na": F(-0.5) * a, "u1": u1, "ea": ea, "ea_tiny": ea + F(1e-30), "a2": a * a}


def _pol(face, p, q, pq, film):
    """One polarization: (c0, g = conj(K e^(iθ)/ζ) as (re, im), w in texels) as lutbake_rt_pol computes them, from
    conj(ζ) (complex values as (re, im) pairs); w = −(1 + ba) + ba (2 + ba)/e, e = ba + ζ."""
    n4 = F(4) / (pq[0] * pq[0] + pq[1] * pq[1])
    scale = face["na"] * n4
    nat2 = (scale * (q[0] * pq[0] + q[1] * pq[1]), scale * (q[0] * pq[1] - q[1] * pq[0]))
    eb = np.maximum((p[0] * q[0] + p[1] * q[1]) * n4, F(0))
    eq = face["ea"] / (face["ea_tiny"] + face["a2"] * eb)
    kr = eb * eq
    c0 = face["a2"] + face["ea"] * (eq - kr)
    abx, em = face["a"] + nat2[0], film["em1c"]
    zc = (face["u1"] + nat2[0] + (abx * em[0] - nat2[1] * em[1]), nat2[1] * film["cos_phase"] + abx * em[1])
    kz = kr / np.maximum(zc[0] * zc[0] + zc[1] * zc[1], F(1e-30))
    g = (kr - kz * zc[0], kz * zc[1])
    ec = (film["ba"] + zc[0], zc[1])
    t = film["kv"] / np.maximum(ec[0] * ec[0] + ec[1] * ec[1], F(1e-30))
    half = film["half"]
    w = (np.clip(film["w0"] + t * ec[0], -half, half), np.clip(t * ec[1], -half, half))
    return c0, g, w


def _film(meta, cos_theta, thickness_nm, eta1, eta2):
    t = meta["table"]
    c1 = np.clip(cos_theta, F(0), F(1))
    e1c = eta1 * c1
    g2 = np.sqrt(np.maximum((eta2 - eta1) * (eta2 + eta1) + e1c * e1c, F(1e-30)))
    h = g2 / (eta2 * eta2)
    xh = thickness_nm * g2
    em1c = _cis_m1_conj(xh * F(2 * t["nu0_per_nm"]))
    ba = xh * F(4 / t["zoom_nm"])
    half = F(0.5 * (t["nodes"] - 1))
    last = F(t["slices"] - 1)
    s = np.minimum(np.sqrt(xh * F(2 * float(last) ** 2 / t["x_max_nm"])), last - F(1 / 4096))
    j = np.floor(s)
    tile = (j + F(0.5)) * F(1 / t["tiles_per_row"])
    nodes = F(t["nodes"])
    centre = ((tile - np.floor(tile)) * F(t["tiles_per_row"] * t["nodes"]), np.floor(tile) * nodes + F(0.5) * nodes)
    return {
        "e1c": e1c,
        "g2r": F(SQRT2) * g2,
        "hr": F(SQRT2) * h,
        "sin2": (eta1 - e1c) * (eta1 + e1c),
        "face_s": _face(e1c, g2),
        "face_p": _face(c1, eta1 * h),
        "em1c": em1c,
        "cos_phase": F(1) + em1c[0],
        "ba": ba,
        "kv": (ba * (F(2) + ba)) * half,  # texels: the same scale on both axes
        "w0": -half - half * ba,
        "half": half,
        "xt": s - j,
        "centre": centre,  # texels
    }


def _base(film, eta1, eta3, kappa3):
    """Both polarizations' (c0, g, w) over one base index per point (g3 and p's admittances scaled by √2)."""
    ek = F(2) * eta3 * kappa3
    zx = (eta3 - eta1) * (eta3 + eta1) - kappa3 * kappa3 + film["e1c"] * film["e1c"]
    g3 = _sqrt2(zx, ek)
    g2r = film["g2r"]
    s = _pol(film["face_s"], (g2r, F(0) * g2r), g3, (g2r + g3[0], g3[1]), film)
    pn = (film["hr"] * (zx + film["sin2"]), film["hr"] * ek)
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


def _read(table: RuntimeTable, film: dict, pol: tuple, band: int, bits: int | None, per_channel: bool) -> np.ndarray:
    """One polarization's read of channel band ``band`` at its w, weighted: Re(K e^(iθ) V / ζ). The slices' blend
    as the include does it: in the weights for ``lutbake_iridescence`` (three reads share them), in the texel for
    ``lutbake_iridescence_rgb`` (one read)."""
    t = table.meta["table"]
    w, g, xt = pol[2], pol[1], film["xt"]
    x = film["centre"][0] + w[0]
    y = film["centre"][1] + w[1] + F(band * t["band_rows"] * t["nodes"])
    v = _bilinear(table.image, x, y, bits)
    if per_channel:
        return (v[:, 0] + (v[:, 2] - v[:, 0]) * xt) * g[0] + (v[:, 1] + (v[:, 3] - v[:, 1]) * xt) * g[1]
    g1 = (g[0] * xt, g[1] * xt)
    return (v * np.stack([g[0] - g1[0], g[1] - g1[1], g1[0], g1[1]], axis=1)).sum(axis=1)


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
        s, p = _base(film, args[1], e3, k3)
        share = F(0.5) * (s[0] + p[0]) + s[1][0] + p[1][0]
        for band in [c] if per_channel else range(3):
            departure = _read(table, film, s, band, filter_bits, per_channel)
            departure = departure + _read(table, film, p, band, filter_bits, per_channel)
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
