"""The shader-side approximations engines run today, in numpy, for the reports.

Both evaluate the Airy sum as a truncated series of orders m, each order's
spectral integral replaced by a Gaussian fit of the CIE 1931 XYZ
sensitivities in Fourier space (Belcour & Barla 2017, §4 and their
supplemental shader), evaluated at OPD m·D·cos θ2 with phase m·φ.

* ``belcour_barla_rgb``: the paper's real-time evaluation. Exact dielectric
  and Born & Wolf conductor Fresnel intensities and phases, orders 0–3,
  per-polarization sums averaged. Born & Wolf write the base index as
  η(1 + iκ_BW), so κ_BW = κ3/η3 is passed (the widely copied shader is often
  fed κ3 unconverted; that is a usage error, not the method's). Its XYZ
  (white E) is taken to the working space through a Bradford adaptation,
  the fair best case (the paper's CIE RGB(E) matrix is no rendering space).
* ``khr_iridescence_rgb``: KHR_materials_iridescence as three.js r187 runs
  it: Schlick at both interfaces (three's exp2 fit of (1 − cos)^5), base
  index recovered from F0 (extinction lost), 0/π phases, orders 0–2, XYZ
  straight through the Rec.709 matrix (no white adaptation) and negative
  values clamped, as shipped (tests/engines/test_runtime_engine.py: three.js's own
  evalIridescence returns it).

* ``exact_mode_rgb`` (lutbake/modes/exact.py) and ``runtime_rgb`` (runtime/model.py): not
  approximations but lutbake's own runtime paths, the exact Fourier series
  summed per pixel from a 1D table, and the six-read runtime table; reported
  beside them so a LUT's error and cost can be weighed against them.

Each takes a film stack of constant indices (points.FilmPoints, fields broadcast);
outputs (…, 3) linear RGB in ``space``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt

from lutbake.modes.exact import exact_mode_rgb
from lutbake.modes.runtime.model import runtime_rgb
from lutbake.physics.colorimetry import colorimetry

if TYPE_CHECKING:
    from lutbake.physics.points import FilmPoints

# (r, φ) of one polarization's Fresnel amplitude: its intensity and phase, each (…)
Fresnel = tuple[np.ndarray, np.ndarray]

__all__ = ["belcour_barla_rgb", "khr_iridescence_rgb", "APPROXIMATIONS"]

# Gaussian fit of the CIE 1931 XYZ sensitivities in Fourier space (per metre of OPD).
_VAL = np.array([5.4856e-13, 4.4201e-13, 5.2481e-13])
_POS = np.array([1.6810e06, 1.7953e06, 2.2084e06])
_VAR = np.array([4.3278e09, 9.3046e09, 6.6121e09])
_X2 = (9.7470e-14, 2.2399e06, 4.5282e09)
_NORM = 1.0685e-7
_XYZ_TO_REC709 = np.array(
    [[3.2404542, -1.5371385, -0.4985314], [-0.9692660, 1.8760108, 0.0415560], [0.0556434, -0.2040259, 1.0572252]]
)


def eval_sensitivity(opd_nm: npt.ArrayLike, shift: npt.ArrayLike) -> np.ndarray:
    """XYZ (…, 3) of the fitted sensitivities at OPD (nm) and phase shift; (1, 1, 1) at 0."""
    opd, shift = np.broadcast_arrays(np.asarray(opd_nm, float), np.asarray(shift, float))
    phase = 2.0 * np.pi * opd * 1e-9
    xyz = (
        _VAL
        * np.sqrt(2 * np.pi * _VAR)
        * np.cos(_POS * phase[..., None] + shift[..., None])
        * np.exp(-_VAR * phase[..., None] ** 2)
    )
    v, p, var = _X2
    xyz[..., 0] += v * np.sqrt(2 * np.pi * var) * np.cos(p * phase + shift) * np.exp(-var * phase**2)
    return xyz / _NORM


def _fresnel_dielectric(cos1: np.ndarray, n1: np.ndarray, n2: np.ndarray) -> list[Fresnel]:
    """(R, φ) per polarization (p, s), as the paper's shader (total reflection: R = 1)."""
    sin2 = 1.0 - cos1**2
    nr = n1 / n2
    tir = nr**2 * sin2 > 1.0
    cos2 = np.sqrt(np.maximum(1.0 - nr**2 * sin2, 0.0))
    r_p = (n2 * cos1 - n1 * cos2) / (n2 * cos1 + n1 * cos2)
    r_s = (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2)
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(np.maximum(sin2 - 1.0 / nr**2, 0.0)) / cos1
    phi_tir = (2 * np.arctan(-(nr**2) * root), 2 * np.arctan(-root))
    out = []
    for r, ph in zip((r_p, r_s), phi_tir):
        out.append((np.where(tir, 1.0, r**2), np.where(tir, ph, np.where(r < 0, np.pi, 0.0))))
    return out


def _fresnel_conductor(cos1: np.ndarray, n1: np.ndarray, n2: np.ndarray, k_bw: np.ndarray) -> list[Fresnel]:
    """Born & Wolf conductor (R, φ) per polarization (p, s); index n2·(1 + i·k_bw)."""
    a = n2**2 * (1 - k_bw**2) - n1**2 * (1 - cos1**2)
    b = np.sqrt(a**2 + (2 * n2**2 * k_bw) ** 2)
    u, v = np.sqrt((a + b) / 2), np.sqrt(np.maximum(b - a, 0.0) / 2)
    r_s = ((n1 * cos1 - u) ** 2 + v**2) / ((n1 * cos1 + u) ** 2 + v**2)
    phi_s = np.arctan2(2 * n1 * v * cos1, u**2 + v**2 - (n1 * cos1) ** 2) + np.pi
    e = n2**2 * (1 - k_bw**2) * cos1
    f = 2 * n2**2 * k_bw * cos1
    r_p = ((e - n1 * u) ** 2 + (f - n1 * v) ** 2) / ((e + n1 * u) ** 2 + (f + n1 * v) ** 2)
    phi_p = np.arctan2(
        2 * n1 * n2**2 * cos1 * (2 * k_bw * u - (1 - k_bw**2) * v),
        (n2**2 * (1 + k_bw**2) * cos1) ** 2 - n1**2 * (u**2 + v**2),
    )
    dielectric = _fresnel_dielectric(cos1, n1, n2)
    conductor = k_bw > 0
    return [
        (np.where(conductor, rc, rd), np.where(conductor, pc, pd))
        for (rc, pc), (rd, pd) in zip(((r_p, phi_p), (r_s, phi_s)), dielectric)
    ]


def _to_space(xyz_e: np.ndarray, space: str, observer: str) -> np.ndarray:
    """XYZ with white E to the working space, Bradford-adapted to its white."""
    cm = colorimetry(observer, space)
    white = cm.rgb_to_xyz(np.ones(3))
    bradford = np.array([[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]])
    scale = (bradford @ white) / (bradford @ np.ones(3))
    adapt = np.linalg.inv(bradford) @ np.diag(scale) @ bradford
    return cm.xyz_to_rgb(xyz_e @ adapt.T)


def _columns(stack: FilmPoints, method: str) -> tuple[np.ndarray, ...]:
    """(η1, η2, η3, κ3, cos θ1, D) of a constant-index stack, broadcast."""
    stack.require(method, film=None, base=None)
    return np.broadcast_arrays(
        *(
            np.asarray(v, float)
            for v in (stack.eta1, stack.eta2, stack.eta3, stack.kappa3, stack.cos_theta, stack.opd_nm)
        )
    )


def belcour_barla_rgb(stack: FilmPoints, space: str = "rec709", observer: str = "cie1931") -> np.ndarray:
    """Belcour & Barla (2017) real-time evaluation, orders 0–3."""
    e1, e2, e3, k3, c1, opd = _columns(stack, "belcour-barla-2017")
    # The shader fades the film to the ambient as D → 0 (its 0.03 µm = 30 nm).
    t = np.clip(opd / 30.0, 0.0, 1.0)
    e2 = e1 + (e2 - e1) * t * t * (3 - 2 * t)
    cos2 = np.sqrt(np.maximum(1 - (e1 / e2) ** 2 * (1 - c1**2), 0.0))
    first = _fresnel_dielectric(c1, e1, e2)
    second = _fresnel_conductor(cos2, e2, e3, k3 / e3)
    xyz = np.zeros(c1.shape + (3,))
    for (r12, phi12), (r23, phi23) in zip(first, second):
        t121 = 1 - r12
        r123 = r12 * r23
        with np.errstate(invalid="ignore", divide="ignore"):
            rs = t121**2 * r23 / (1 - r123)
        c0 = r12 + rs
        xyz += 0.5 * c0[..., None] * eval_sensitivity(np.zeros_like(c1), 0.0)
        cm_ = rs - t121
        phi2 = (np.pi - phi12) + phi23
        for m in (1, 2, 3):
            cm_ = cm_ * np.sqrt(r123)
            xyz += 0.5 * (cm_[..., None] * 2.0 * eval_sensitivity(m * opd * cos2, m * phi2))
    return _to_space(np.nan_to_num(xyz), space, observer)


def _schlick(f0: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """three.js's F_Schlick (r187): the exp2 fit of (1 − cos)^5 (Epic, SIGGRAPH 2013), not the power itself."""
    fresnel = np.exp2((-5.55473 * cos - 6.98316) * cos)
    return f0 * (1 - fresnel) + fresnel


def _schlick_as_specified(f0: np.ndarray, cos: np.ndarray) -> np.ndarray:
    """glTF's F_Schlick (Appendix B.3.4): F0 + (1 − F0)(1 − cos)^5."""
    return f0 + (1 - f0) * (1 - cos) ** 5


def khr_iridescence_rgb(
    stack: FilmPoints, space: str = "rec709", observer: str = "cie1931", as_specified: bool = False
) -> np.ndarray:
    """KHR_materials_iridescence as in three.js' evalIridescence, orders 0–2; ``as_specified``: as the
    extension's text writes it (glTF's model: Schlick's power, no fade of the film's index at thin films)."""
    e1, e2, e3, k3, c1, opd = _columns(stack, "khr-iridescence-threejs")
    thickness = opd / (2 * e2)
    t = np.clip(thickness / 0.03, 0.0, 1.0)  # three.js fades over 0.03 *nm* (its thickness is in nm)
    ior = e2 if as_specified else e1 + (e2 - e1) * t * t * (3 - 2 * t)
    schlick = _schlick_as_specified if as_specified else _schlick
    cos2_sq = 1 - (e1 / ior) ** 2 * (1 - c1**2)
    cos2 = np.sqrt(np.maximum(cos2_sq, 0.0))
    r12 = schlick(((ior - e1) / (ior + e1)) ** 2, c1)
    t121 = 1 - r12
    phi21 = np.pi - np.where(ior < e1, np.pi, 0.0)
    base_f0 = np.clip(((e3 - 1) ** 2 + k3**2) / ((e3 + 1) ** 2 + k3**2), 0.0, 0.9999)  # metal F0, air reference
    base_ior = (1 + np.sqrt(base_f0)) / (1 - np.sqrt(base_f0))
    r23 = schlick(((base_ior - ior) / (base_ior + ior)) ** 2, cos2)
    phi = phi21 + np.where(base_ior < ior, np.pi, 0.0)
    r123 = np.clip(r12 * r23, 1e-5, 0.9999)
    rs = t121**2 * r23 / (1 - r123)
    rgb = (r12 + rs)[..., None] * np.ones(3)
    cm_ = rs - t121
    for m in (1, 2):
        cm_ = cm_ * np.sqrt(r123)
        rgb += cm_[..., None] * 2.0 * (eval_sensitivity(m * 2 * ior * thickness * cos2, m * phi) @ _XYZ_TO_REC709.T)
    rgb = np.where((cos2_sq < 0)[..., None], 1.0, np.maximum(rgb, 0.0))
    if space != "rec709":
        cm709, cm = colorimetry(observer, "rec709"), colorimetry(observer, space)
        rgb = cm.xyz_to_rgb(cm709.rgb_to_xyz(rgb))
    return rgb


class Approximation(Protocol):
    """An engine approximation: RGB of ``stack`` in colour ``space`` under ``observer``."""

    def __call__(self, stack: FilmPoints, space: str, observer: str) -> np.ndarray: ...


APPROXIMATIONS: dict[str, Approximation] = {
    "belcour-barla-2017": belcour_barla_rgb,
    "khr-iridescence-threejs": khr_iridescence_rgb,
    "lutbake-exact-mode": exact_mode_rgb,
    "lutbake-runtime": runtime_rgb,
}
