"""The Airy reflectance of a constant, lossless, propagating film as a function of its phase alone.

For a stack whose indices do not depend on λ (no named material) and whose film carries a propagating
wave (g2 = η2 cos θ2 real and > 0: η2 > η1 sin θ1), the Fresnel amplitudes r12 (real: Y1, Y2 are
real) and r23 (complex over a metal) are constants of the point, and only z = exp(iΦ), Φ = 4π d g2 / λ,
varies along the spectrum. Per polarization (module optics' admittances Y1, Y2, Y3)::

    r = (r12 + r23 z) / (1 + q z),   r12 = (Y1 − Y2)/(Y1 + Y2),  r23 = (Y2 − Y3)/(Y2 + Y3),  q = r12 r23

(optics' rearranged form multiplied by Y2 / ((Y1 + Y2)(Y2 + Y3))). With |u + v z|² = |u|² + |v|² +
2|u||v| cos(Φ + arg v − arg u) and 1 + cos x = 2 cos²(x/2)::

    R = [(|r12| − |r23|)² + 4 |r12| |r23| cos²(Φ/2 + β)] / [(1 − |q|)² + 4 |q| cos²(Φ/2 + δ)]

with β = (arg r23 − arg r12)/2 and δ = arg q / 2. Both sums have non-negative terms, so neither
cancels: where the film resonates (|q| → 1 at grazing incidence over a near-totally reflecting base,
the denominator's minimum (1 − |q|)² tiny) the minimum is computed to a few ulps from
1 − |q|² = (1 − r12²) + r12² (1 − |r23|²), 1 − r12² = 4 Y1 Y2 / (Y1 + Y2)², 1 − |r23|² =
4 Y2 Re Y3 / |Y2 + Y3|², never as 1 + |q|² − 2|q|, whose rounding would be (1 − |q|)⁻² times larger.
The numerator's difference |r12| − |r23| is taken as (1 − |r23|²)/(1 + |r23|) − (1 − r12²)/(1 + |r12|)
(both near 1 at grazing incidence over a base matching the ambient, their difference still sets R); it may
cancel near R = 0, which costs R relative, not absolute, precision; above R = 1/2 the numerator is taken
as the denominator less (1 − r12²)(1 − |r23|²) (R + T = 1, as optics takes 1 − T), so the cancellation
never costs absolute precision where R is large.
cos(Φ/2 + β) = cos(Φ/2) cos β − sin(Φ/2) sin β, with e^{iβ} and e^{iδ} from exact half-angle phasors (no
angle, no cos(π/2) residue): one cos and one sin of Φ/2 per wavelength serve both polarizations and both
sums; the rest is per point (docs/optics.md).

Rounding model (tests/physics/test_fringes.py): R is backward stable like optics.film_reflectance, the
exact R of inputs each within a few u (u = 2⁻⁵³) of theirs, so its error is bounded by the same
sensitivity Σᵢ |xᵢ ∂R/∂xᵢ| (the phase's Φ ∂R/∂Φ, large in thick or high-finesse films, included).
Points outside the model — a named (dispersive) material, an evanescent film or one less dense than the
ambient near its critical angle (η2 < η1 and g2 < MIN_FILM_COS·η2), cos θ1 ≤ MIN_COS (grazing, where
optics sets r = −1, and subnormal angles whose squares underflow) — are for optics.film_reflectance
(lutbake/spectral/reference.py picks per point).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lutbake.physics.optics import normal_admittance

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from lutbake.physics.points import FilmPoints

__all__ = ["FringeTerms", "fringe_terms", "fringe_polarized", "fringe_reflectance", "fringe_points"]

# Below MIN_COS the squares of the per-point terms could leave float64's normal range (1e-30² ≫ 1e-308).
# Near the critical angle of a film less dense than the ambient (η2 < η1, g2 → 0 while Y1 does not)
# r12 → 1 and r23 → −1 make both sums 0/0-like (optics' W form avoids the division by g2 that this form
# hides): at cos θ2 = g2/η2 ~ 2e-3 the error reached 5x the backward bound, at ≥ 0.03 under a tenth of it,
# so such a film must lean less than arccos(MIN_FILM_COS) ≈ 86.4°. A film at least as dense as the ambient
# has g2 ≥ Y1: small g2 only at grazing incidence, where r12 stays ≤ 0 and nothing cancels (tested down to
# cos θ1 = 1e-12 with η2 = η1(1 + 1e-12)). Points outside take optics' path, which handles them by construction.
MIN_COS = 1e-30
MIN_FILM_COS = 1.0 / 16.0


@dataclass(frozen=True)
class FringeTerms:
    """Per point (each (P, 1)): Φ/2 = half_phase_nm / λ, and per polarization (rows s, p; each (2, P, 1))
    the cos² weight 4|q|, the numerator's and the denominator's floors and the cos, sin of their phase
    shifts β, δ, and (1 − r12²)(1 − |r23|²), the power the film passes on (R = 1 − it / denominator)."""

    half_phase_nm: np.ndarray
    weight: np.ndarray
    num_floor: np.ndarray
    num_cos: np.ndarray
    num_sin: np.ndarray
    den_floor: np.ndarray
    den_cos: np.ndarray
    den_sin: np.ndarray
    transmitted: np.ndarray


def fringe_points(stack: FilmPoints) -> np.ndarray:
    """(P,) True where ``fringe_reflectance`` applies: constant indices, cos θ1 > MIN_COS and a propagating
    wave in the lossless film (g2 real > 0), at least as dense as the ambient or leaning less than its
    critical angle allows (g2 ≥ MIN_FILM_COS·η2)."""
    if stack.film is not None or stack.base is not None:
        return np.zeros(len(stack), bool)
    e1, e2, c1 = np.broadcast_arrays(*(np.asarray(v, float) for v in (stack.eta1, stack.eta2, stack.cos_theta)))
    g2 = normal_admittance(e2, 0.0, e1, c1)
    leaning = (e2 >= e1) | (g2.real >= MIN_FILM_COS * e2)  # a film denser than the ambient has no critical angle
    return np.asarray((c1 > MIN_COS) & (g2.imag == 0) & (g2.real > 0) & leaning).reshape(len(stack))


def _polarization(y1: np.ndarray, y2: np.ndarray, y3: np.ndarray) -> tuple[np.ndarray, ...]:
    """(num_floor, weight, e^{iβ}, den_floor, e^{iδ}, transmitted) of one polarization (Y1, Y2 real > 0): the
    numerator's and the denominator's cos² terms share the weight 4|q|."""
    r12 = (y1 - y2) / (y1 + y2)
    r23 = (y2 - y3) / (y2 + y3)
    a12, a23 = np.abs(r12), np.abs(r23)
    # 1 − |q|² as a sum of non-negative terms (module docstring); Re Y3 < 0 only from rounding.
    loss12 = 4.0 * y1 * y2 / ((y1 + y2) * (y1 + y2))
    loss23 = 4.0 * y2 * np.maximum(y3.real, 0.0) / np.abs(y2 + y3) ** 2
    q = a12 * a23
    one_minus_q = (loss12 + a12 * a12 * loss23) / (1.0 + q)
    # e^{iβ}, e^{iδ} from half-angle phasors, never from angles: a quarter turn is exact (cos(π/2) would leave
    # 6e-17, which a thin film's tiny cos(Φ/2 + β) near a 0/0 cannot absorb); the branch of each half angle
    # (± the phasor) only flips the sign of cos(Φ/2 + β), which enters squared.
    half12 = np.where(r12 < 0, 1j, 1.0 + 0j)
    with np.errstate(invalid="ignore", divide="ignore"):
        half23 = np.where(a23 > 0, np.sqrt(r23 / a23), 1.0 + 0j)
    # |r12| − |r23| as (1 − |r23|) − (1 − |r12|), each from its loss: at grazing incidence over a base that
    # nearly matches the ambient both round to 1 while their difference (~ the losses, 1e-17) still sets R.
    gap = loss23 / (1.0 + a23) - loss12 / (1.0 + a12)
    return gap * gap, 4.0 * q, half23 * np.conj(half12), one_minus_q**2, half12 * half23, loss12 * loss23


def fringe_terms(stack: FilmPoints) -> FringeTerms:
    """The per-point terms of ``stack`` (every point must satisfy ``fringe_points``), as (P, 1) columns."""
    fields = (stack.eta1, stack.eta2, stack.eta3, stack.kappa3, stack.cos_theta, stack.thickness_nm)
    e1, e2, e3, k3, c1, d = (v.reshape(-1, 1) for v in np.broadcast_arrays(*(np.asarray(v, float) for v in fields)))
    g1 = e1 * c1
    g2 = normal_admittance(e2, 0.0, e1, c1).real
    g3 = normal_admittance(e3, k3, e1, c1)
    n3 = e3 + 1j * k3
    # p: optics' dual admittances scaled by η1² (r is unchanged by a common factor)
    s = _polarization(g1, g2, g3)
    p = _polarization(g1, g2 * (e1 / e2) ** 2, g3 * (e1 * e1 / n3**2))
    num_floor, weight, beta, den_floor, delta, transmitted = (np.stack([a, b]) for a, b in zip(s, p))
    return FringeTerms(
        half_phase_nm=2.0 * np.pi * d * g2,
        weight=weight,
        num_floor=num_floor,
        num_cos=beta.real,
        num_sin=beta.imag,
        den_floor=den_floor,
        den_cos=delta.real,
        den_sin=delta.imag,
        transmitted=transmitted,
    )


def fringe_polarized(terms: FringeTerms, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(R_s, R_p) of the points of ``terms`` at ``wavelength_nm``, broadcast as optics.film_reflectance
    ((P, 1) columns against a row of M wavelengths give (P, M))."""
    half = terms.half_phase_nm / np.asarray(wavelength_nm, float)
    cos_half, sin_half = np.cos(half), np.sin(half)
    out = []
    for pol in (0, 1):
        num = _weighted_cos_squared(cos_half, sin_half, terms.num_cos[pol], terms.num_sin[pol], terms.weight[pol])
        num += terms.num_floor[pol]
        den = _weighted_cos_squared(cos_half, sin_half, terms.den_cos[pol], terms.den_sin[pol], terms.weight[pol])
        den += terms.den_floor[pol]
        # Above R = 1/2 the numerator is the denominator less the passed-on power (R + T = 1 for a lossless
        # film): 1 − R keeps its relative precision where the direct sum's |r12| − |r23| cancels.
        np.subtract(den, terms.transmitted[pol], out=num, where=num > 0.5 * den)
        num /= den
        out.append(num)
    return out[0], out[1]


def fringe_reflectance(terms: FringeTerms, wavelength_nm: ArrayLike) -> np.ndarray:
    """Unpolarized R = (R_s + R_p)/2, shaped as ``fringe_polarized``'s."""
    r_s, r_p = fringe_polarized(terms, wavelength_nm)
    r_s += r_p
    r_s *= 0.5
    return r_s


def _weighted_cos_squared(
    cos_half: np.ndarray, sin_half: np.ndarray, cos_shift: np.ndarray, sin_shift: np.ndarray, weight: np.ndarray
) -> np.ndarray:
    """weight·cos²(Φ/2 + shift) from cos, sin of Φ/2 and of the shift, in a fresh array."""
    out = cos_half * cos_shift
    out -= sin_half * sin_shift
    out *= out
    out *= weight
    return out
