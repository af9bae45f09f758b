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

Reference: CIE 015:2018 Colorimetry, 4th ed.; colour-science 0.4
(colour.MSDS_CMFS, colour.RGB_COLOURSPACES, colour.delta_E).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np

from .names import OBSERVERS, SPACES

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



@functools.lru_cache(maxsize=1)
def _colour():
    """colour-science, imported on first use: it pulls in matplotlib (~1 s), which `--help` never needs."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour

    return colour


class Colorimetry:
    """The sensitivities of one (observer, working space) pair on the 1 nm grid."""

    def __init__(self, observer: str = "cie1931", space: str = "rec709"):
        if observer not in OBSERVERS:
            raise ValueError(f"observer {observer!r} is not one of {', '.join(OBSERVERS)}")
        if space not in SPACES:
            raise ValueError(f"space {space!r} is not one of {', '.join(SPACES)}")
        self.observer, self.space = observer, space
        colour = _colour()
        self.colourspace = colour.RGB_COLOURSPACES[SPACES[space]]
        self.wavelength_nm = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM + 0.5, 1.0)
        cmfs = colour.MSDS_CMFS[OBSERVERS[observer]]
        cmf = np.asarray(cmfs.values, float)[:, :3]
        self.illuminant = self._illuminant()
        table = cmf * self.illuminant[:, None]
        self.xyz_table = (table / _trapezoid(table[:, 1])).T  # (3, 471), Y of flat 1 is 1
        rgb = self.colourspace.matrix_XYZ_to_RGB @ self.xyz_table
        self.rgb_table = rgb / _trapezoid(rgb, axis=1)[:, None]

    def _illuminant(self):
        """The space's white as a spectrum on the 1 nm grid.

        D65 spaces use the CIE D65 table (colour-science's copy ends at
        780 nm; beyond it the D-series shape takes over, scaled to join).
        Other whites (ACES ≈ D60) use the CIE daylight series at the space's
        white chromaticity.
        """
        lam = self.wavelength_nm
        colour = _colour()
        daylight = colour.sd_CIE_illuminant_D_series(np.asarray(self.colourspace.whitepoint, float))
        series = np.interp(lam, daylight.wavelengths, daylight.values)
        if self.colourspace.whitepoint_name != "D65":
            return series
        d65 = colour.SDS_ILLUMINANTS["D65"]
        table = np.interp(lam, d65.wavelengths, d65.values)
        end = d65.wavelengths[-1]
        join = table[lam == end][0] / series[lam == end][0]
        return np.where(lam <= end, table, series * join)

    def sensitivity(self, wavelength_nm, basis: str = "rgb") -> np.ndarray:
        """Continuous w_c(λ) (3, …), linear between the 1 nm table entries."""
        table = self.rgb_table if basis == "rgb" else self.xyz_table
        lam = np.asarray(wavelength_nm, float)
        return np.stack([np.interp(lam, self.wavelength_nm, row, left=0.0, right=0.0)
                         for row in table])

    def rgb_to_xyz(self, rgb) -> np.ndarray:
        """Linear working-space RGB (…, 3) to XYZ (…, 3), Y of the white = 1."""
        return np.asarray(rgb, float) @ self.colourspace.matrix_RGB_to_XYZ.T

    def xyz_to_rgb(self, xyz) -> np.ndarray:
        return np.asarray(xyz, float) @ self.colourspace.matrix_XYZ_to_RGB.T


@functools.lru_cache(maxsize=16)
def colorimetry(observer: str = "cie1931", space: str = "rec709") -> Colorimetry:
    """Cached Colorimetry (building one reads colour-science's tables)."""
    return Colorimetry(observer, space)


def delta_e00(rgb_a, rgb_b, observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """CIEDE2000 between two linear RGB arrays (…, 3) in CIELAB with the space's white.

    Reflectance is taken as Y ≤ 1 (the white reflector has Y = 1).
    """
    cm, colour = colorimetry(observer, space), _colour()
    xy_white = colour.XYZ_to_xy(cm.rgb_to_xyz(np.ones(3)))
    lab = [colour.XYZ_to_Lab(cm.rgb_to_xyz(v), xy_white) for v in (rgb_a, rgb_b)]
    return np.asarray(colour.delta_E(lab[0], lab[1], method="CIE 2000"))


def _trapezoid(values, axis=-1):
    """∫ over the 1 nm grid of a piecewise-linear function sampled on it."""
    v = np.asarray(values, float)
    return np.sum(v, axis=axis) - 0.5 * (np.take(v, 0, axis=axis) + np.take(v, -1, axis=axis))
