"""Colorimetry: observers, working spaces, illuminant-weighted sensitivities, ΔE00.

The continuous sensitivity of channel c is w_c(λ) = CMF_c(λ)·S(λ), where the
CMFs are the CIE 1 nm tables (360–830 nm) and S is the CIE daylight
(D-series) illuminant at the working space's white chromaticity, both
interpolated linearly between 1 nm samples (CIE 015's recommendation for the
D series). XYZ = ∫ CMF·S·R dλ / ∫ ȳ·S dλ, so a perfect reflector has Y = 1.

RGB weights are the XYZ weights through the space's XYZ→RGB matrix, each
channel then scaled so that a spectrally flat reflectance ρ gives exactly
(ρ, ρ, ρ). The scale corrects the small mismatch (≈1e-4) between the
illuminant's integrated white and the space's rounded white point.

colour-science supplies the tables (CMFs, illuminants, the spaces' matrices
and whites); they are kept in the user's cache (lutbake/io/usercache.py, keyed by
colour-science's version), because importing colour-science costs ~2 s per
process. ΔE00 is computed here (CIE 15 CIELAB, Sharma et al.'s CIEDE2000) and
checked against colour.delta_E in the tests.

References: CIE 015:2018 Colorimetry, 4th ed.; G. Sharma, W. Wu, E. N. Dalal,
"The CIEDE2000 color-difference formula", Color Res. Appl. 30 (2005);
colour-science 0.4 (colour.MSDS_CMFS, colour.RGB_COLOURSPACES).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from lutbake.io.names import OBSERVERS, SPACES
from lutbake.io.usercache import cached_arrays

if TYPE_CHECKING:
    from colour.models import RGB_Colourspace
    from numpy.typing import ArrayLike

__all__ = [
    "OBSERVERS",
    "SPACES",
    "WAVELENGTH_MIN_NM",
    "WAVELENGTH_MAX_NM",
    "Colorimetry",
    "colorimetry",
    "delta_e00",
]

WAVELENGTH_MIN_NM = 360.0
WAVELENGTH_MAX_NM = 830.0


def _colour() -> ModuleType:
    """colour-science, imported only to fill the cache: it pulls in matplotlib (~2 s in all), which logs
    two warnings when the user's cache home cannot be written (it then uses a temporary folder)."""
    import logging

    quiet = logging.getLogger("matplotlib")
    level = quiet.level
    quiet.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import colour
    finally:
        quiet.setLevel(level)
    return colour


_WAVELENGTHS = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM + 0.5, 1.0)
_TABLE_SHAPES = {
    "cmf": (_WAVELENGTHS.size, 3),
    "illuminant": (_WAVELENGTHS.size,),
    "xyz_to_rgb": (3, 3),
    "rgb_to_xyz": (3, 3),
    "whitepoint_xy": (2,),
}


def _colour_science_tables(observer: str, space: str) -> Mapping[str, np.ndarray]:
    """CMFs and illuminant on the 1 nm grid, and the space's matrices and white, from colour-science."""
    from importlib.metadata import version

    key = f"{version('colour-science')}|{OBSERVERS[observer]}|{SPACES[space]}".encode()
    return cached_arrays("colour-tables", key, _TABLE_SHAPES, lambda: _read_colour_science(observer, space))


def _read_colour_science(observer: str, space: str) -> dict[str, np.ndarray]:
    colour = _colour()
    colourspace = colour.RGB_COLOURSPACES[SPACES[space]]
    cmfs = colour.MSDS_CMFS[OBSERVERS[observer]]
    return {
        "cmf": np.asarray(cmfs.values, float)[:, :3],
        "illuminant": _illuminant(colour, colourspace),
        "xyz_to_rgb": np.asarray(colourspace.matrix_XYZ_to_RGB, float),
        "rgb_to_xyz": np.asarray(colourspace.matrix_RGB_to_XYZ, float),
        "whitepoint_xy": np.asarray(colourspace.whitepoint, float),
    }


def _illuminant(colour: ModuleType, colourspace: RGB_Colourspace) -> np.ndarray:
    """The space's white as a spectrum on the 1 nm grid.

    D65 spaces use the CIE D65 table (colour-science's copy ends at
    780 nm; beyond it the D-series shape takes over, scaled to join).
    Other whites (ACES ≈ D60) use the CIE daylight series at the space's
    white chromaticity.
    """
    lam = _WAVELENGTHS
    daylight = colour.sd_CIE_illuminant_D_series(np.asarray(colourspace.whitepoint, float))
    series = np.interp(lam, daylight.wavelengths, daylight.values)
    if colourspace.whitepoint_name != "D65":
        return series
    d65 = colour.SDS_ILLUMINANTS["D65"]
    table = np.interp(lam, d65.wavelengths, d65.values)
    end = d65.wavelengths[-1]
    join = table[lam == end][0] / series[lam == end][0]
    return np.where(lam <= end, table, series * join)


class Colorimetry:
    """The sensitivities of one (observer, working space) pair on the 1 nm grid."""

    def __init__(self, observer: str = "cie1931", space: str = "rec709") -> None:
        if observer not in OBSERVERS:
            raise ValueError(f"observer {observer!r} is not one of {', '.join(OBSERVERS)}")
        if space not in SPACES:
            raise ValueError(f"space {space!r} is not one of {', '.join(SPACES)}")
        self.observer, self.space = observer, space
        tables = _colour_science_tables(observer, space)
        self.wavelength_nm = _WAVELENGTHS
        self.illuminant = tables["illuminant"]
        self.whitepoint_xy = tables["whitepoint_xy"]
        self.matrix_xyz_to_rgb, self.matrix_rgb_to_xyz = tables["xyz_to_rgb"], tables["rgb_to_xyz"]
        table = tables["cmf"] * self.illuminant[:, None]
        self.xyz_table = (table / _trapezoid(table[:, 1])).T  # (3, 471), Y of flat 1 is 1
        rgb = self.matrix_xyz_to_rgb @ self.xyz_table
        self.rgb_table = rgb / _trapezoid(rgb, axis=1)[:, None]

    def sensitivity(self, wavelength_nm: ArrayLike, basis: str = "rgb") -> np.ndarray:
        """Continuous w_c(λ) (3, …), linear between the 1 nm table entries."""
        table = self.rgb_table if basis == "rgb" else self.xyz_table
        lam = np.asarray(wavelength_nm, float)
        return np.stack([np.interp(lam, self.wavelength_nm, row, left=0.0, right=0.0) for row in table])

    def rgb_to_xyz(self, rgb: ArrayLike) -> np.ndarray:
        """Linear working-space RGB (…, 3) to XYZ (…, 3), Y of the white = 1."""
        return np.asarray(rgb, float) @ self.matrix_rgb_to_xyz.T

    def xyz_to_rgb(self, xyz: ArrayLike) -> np.ndarray:
        """XYZ (…, 3) to linear working-space RGB (…, 3)."""
        return np.asarray(xyz, float) @ self.matrix_xyz_to_rgb.T


@functools.lru_cache(maxsize=16)
def colorimetry(observer: str = "cie1931", space: str = "rec709") -> Colorimetry:
    """Cached Colorimetry (building one reads colour-science's tables)."""
    return Colorimetry(observer, space)


def delta_e00(rgb_a: ArrayLike, rgb_b: ArrayLike, observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """CIEDE2000 between two linear RGB arrays (…, 3) in CIELAB with the space's white.

    Reflectance is taken as Y ≤ 1 (the white reflector has Y = 1).
    """
    cm = colorimetry(observer, space)
    white = cm.rgb_to_xyz(np.ones(3))
    white = white / white[1]  # CIELAB's reference white: the space's white chromaticity at Y = 1
    return _ciede2000(_lab(cm.rgb_to_xyz(rgb_a), white), _lab(cm.rgb_to_xyz(rgb_b), white))


def _lab(xyz: ArrayLike, white: np.ndarray) -> np.ndarray:
    """CIE 1976 L*a*b* (CIE 15), with the exact constants ε = 216/24389, κ = 24389/27."""
    t = np.asarray(xyz, float) / white
    f = np.where(t > 216.0 / 24389.0, np.cbrt(t), (24389.0 / 27.0 * t + 16.0) / 116.0)
    return np.stack(
        [116.0 * f[..., 1] - 16.0, 500.0 * (f[..., 0] - f[..., 1]), 200.0 * (f[..., 1] - f[..., 2])], axis=-1
    )


def _ciede2000(lab1: np.ndarray, lab2: np.ndarray) -> np.ndarray:
    """ΔE00 with kL = kC = kH = 1 (Sharma, Wu & Dalal 2005, eqs. 1–22)."""
    (l1, a1, b1), (l2, a2, b2) = np.moveaxis(lab1, -1, 0), np.moveaxis(lab2, -1, 0)
    c_mean = 0.5 * (np.hypot(a1, b1) + np.hypot(a2, b2))
    g = 0.5 * (1.0 - np.sqrt(c_mean**7 / (c_mean**7 + 25.0**7)))
    a1p, a2p = (1.0 + g) * a1, (1.0 + g) * a2
    c1p, c2p = np.hypot(a1p, b1), np.hypot(a2p, b2)
    h1p = np.where((a1p == 0) & (b1 == 0), 0.0, np.degrees(np.arctan2(b1, a1p)) % 360.0)
    h2p = np.where((a2p == 0) & (b2 == 0), 0.0, np.degrees(np.arctan2(b2, a2p)) % 360.0)
    chroma_product = c1p * c2p
    dh = h2p - h1p
    dh = np.where(dh > 180.0, dh - 360.0, np.where(dh < -180.0, dh + 360.0, dh))
    dh = np.where(chroma_product == 0, 0.0, dh)
    d_l, d_c = l2 - l1, c2p - c1p
    d_h = 2.0 * np.sqrt(chroma_product) * np.sin(np.radians(0.5 * dh))
    l_mean, cp_mean = 0.5 * (l1 + l2), 0.5 * (c1p + c2p)
    h_sum = h1p + h2p
    h_mean = np.where(
        np.abs(h1p - h2p) <= 180.0, 0.5 * h_sum, np.where(h_sum < 360.0, 0.5 * (h_sum + 360.0), 0.5 * (h_sum - 360.0))
    )
    h_mean = np.where(chroma_product == 0, h_sum, h_mean)
    t = (
        1.0
        - 0.17 * np.cos(np.radians(h_mean - 30.0))
        + 0.24 * np.cos(np.radians(2.0 * h_mean))
        + 0.32 * np.cos(np.radians(3.0 * h_mean + 6.0))
        - 0.20 * np.cos(np.radians(4.0 * h_mean - 63.0))
    )
    rotation = 30.0 * np.exp(-(((h_mean - 275.0) / 25.0) ** 2))
    r_c = 2.0 * np.sqrt(cp_mean**7 / (cp_mean**7 + 25.0**7))
    s_l = 1.0 + 0.015 * (l_mean - 50.0) ** 2 / np.sqrt(20.0 + (l_mean - 50.0) ** 2)
    s_c, s_h = 1.0 + 0.045 * cp_mean, 1.0 + 0.015 * cp_mean * t
    r_t = -np.sin(np.radians(2.0 * rotation)) * r_c
    terms = d_l / s_l, d_c / s_c, d_h / s_h
    return np.sqrt(terms[0] ** 2 + terms[1] ** 2 + terms[2] ** 2 + r_t * terms[1] * terms[2])


def _trapezoid(values: ArrayLike, axis: int = -1) -> np.ndarray:
    """∫ over the 1 nm grid of a piecewise-linear function sampled on it."""
    v = np.asarray(values, float)
    return np.sum(v, axis=axis) - 0.5 * (np.take(v, 0, axis=axis) + np.take(v, -1, axis=axis))
