"""Thin-film optics: Fresnel amplitudes and the closed-form Airy summation.

A film of real index η2 and physical thickness d lies between an ambient of
real index η1 and a base of complex index n3 = η3 + iκ3 (κ ≥ 0 absorbs):
a film stack (points.FilmPoints), lit at cos θ1. Everything is float64 numpy,
vectorized: the stack's fields and the wavelengths broadcast together.

Each medium j is described by its *normal admittance* g_j = n_j cos θ_j =
√(n_j² − η1² sin² θ1) (principal root, Im ≥ 0), which makes total internal
reflection at either interface, evanescent films, grazing incidence and
absorbing bases ordinary complex arithmetic (no special cases, no arctan
phase traps). The p polarization uses the dual admittance Y = g / n², which
stays finite at grazing incidence; s uses Y = g.

The reflected amplitude is the Airy sum of the seed document (Belcour &
Barla 2017, supplemental §1–2)::

    r = r12 + t12 t21 r23 z / (1 − r21 r23 z) = (r12 + r23 z) / (1 + r12 r23 z)

with z = exp(iΦ), Φ = 4π d g2 / λ = 2π D cos θ2 / λ. Multiplying through by
(Y1 + Y2)(Y2 + Y3)/Y2 gives the algebraically identical form evaluated here::

    r = [2(Y1 − Y3) + (Y1 + Y2)(Y2 − Y3) W] / [2(Y1 + Y3) + (Y1 − Y2)(Y2 − Y3) W]

with W = (z − 1)/Y2 = i (4π d / λ) · exprel(iΦ) · (1 for s, n2² for p).
W has no division by g2, so the film's own critical angle (g2 → 0) costs no
precision, and |z| ≤ 1 keeps thick evanescent films finite. docs/optics.md
derives it; tests compare it with the textbook sum at 50 digits (mpmath)
and with tmm's transfer matrices.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from lutbake.physics.points import FilmPoints

    # per polarization ('s', 'p'): the admittances (Y1, Y2, Y3) and W of the stack
    _Terms = dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]

__all__ = [
    "normal_admittance",
    "fresnel_s",
    "fresnel_p",
    "film_amplitudes",
    "film_reflectance",
    "film_transmittance",
    "round_trip_amplitude",
]


def normal_admittance(eta: ArrayLike, kappa: ArrayLike, eta1: ArrayLike, cos_theta1: ArrayLike) -> np.ndarray:
    """g = n cos θ = √(n² − η1² sin² θ1) for n = η + iκ, principal root.

    The squared term's imaginary part 2ηκ is built as a real ≥ 0 so that a
    negative real radicand (total internal reflection) takes the +i branch
    (a decaying wave), never the −i one a signed zero could select. The real
    part is ((η − η1)(η + η1) − κ²) + η1² cos² θ1, exact when η = η1 at grazing
    incidence, where η² − η1² sin² θ1 would cancel.
    """
    eta, kappa = np.asarray(eta, float), np.asarray(kappa, float)
    e1 = np.asarray(eta1, float)
    cos1 = np.asarray(cos_theta1, float)
    # n² − η1² factored so that η = η1 gives exactly −κ² (the kernel does the same).
    offset = (eta - e1) * (eta + e1) - kappa * kappa
    im = 2.0 * eta * kappa
    g = np.sqrt((offset + e1 * e1 * cos1 * cos1) + 1j * im)
    # A medium matching the ambient has g = η1 cos θ1 exactly (cos² may underflow).
    return np.where((offset == 0) & (im == 0), e1 * cos1 + 0j, g)


def fresnel_s(g_i: np.ndarray, g_j: np.ndarray) -> np.ndarray:
    """s (TE) amplitude reflection r = (g_i − g_j)/(g_i + g_j) from medium i into j."""
    return (g_i - g_j) / (g_i + g_j)


def fresnel_p(g_i: np.ndarray, g_j: np.ndarray, n_i: complex | np.ndarray, n_j: complex | np.ndarray) -> np.ndarray:
    """p (TM) amplitude reflection (n_j² g_i − n_i² g_j)/(n_j² g_i + n_i² g_j).

    Sign convention of tmm (r_p = r_s at normal incidence would be the other
    one); only |r|² and relative phases between interfaces enter R.
    """
    a, b = n_j**2 * g_i, n_i**2 * g_j
    return (a - b) / (a + b)


def _exprel(x: ArrayLike) -> np.ndarray:
    """(eˣ − 1)/x for complex x with Re x ≤ 0, equal to 1 at x = 0."""
    x = np.asarray(x, complex)
    small = np.abs(x) < 1e-8
    safe = np.where(small, 1.0, x)
    return np.where(small, 1.0 + x / 2.0, _expm1(safe) / safe)


def _expm1(x: np.ndarray) -> np.ndarray:
    """eˣ − 1 for complex x, numpy's formula for it (expm1(Re x)·cos(Im x) − 2 sin²(Im x / 2) + i e^{Re x}
    sin(Im x)) on real arrays: numpy's vectorized sin/cos/exp, where np.expm1 of a complex array calls
    libm per element (~7x slower)."""
    re, im = x.real, x.imag
    half = np.sin(im / 2)
    out = np.empty(x.shape, complex)
    np.subtract(np.expm1(re) * np.cos(im), 2 * half * half, out=out.real)
    np.multiply(np.exp(re), np.sin(im), out=out.imag)
    return out


def _stack_terms(
    eta1: ArrayLike,
    eta2: ArrayLike,
    eta3: ArrayLike,
    kappa3: ArrayLike,
    cos_theta1: ArrayLike,
    thickness_nm: ArrayLike,
    wavelength_nm: ArrayLike,
) -> tuple[_Terms, np.ndarray, np.ndarray]:
    """Admittances (Y1, Y2, Y3) per polarization, the phase Φ and W for each (indices resolved). The
    admittances keep the indices' and cos θ1's shape (a stack's (P, 1) columns: once per point, not once
    per wavelength node); Φ and W broadcast against the thickness and the wavelengths."""
    e1, e2, e3, k3, c1 = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (eta1, eta2, eta3, kappa3, cos_theta1))
    )
    d, lam = np.asarray(thickness_nm, float), np.asarray(wavelength_nm, float)
    g1 = e1 * c1 + 0j
    g2 = normal_admittance(e2, 0.0, e1, c1)
    g3 = normal_admittance(e3, k3, e1, c1)
    n3 = e3 + 1j * k3
    four_pi_d = 4.0 * np.pi * d / lam
    phi = four_pi_d * g2
    w_s = 1j * four_pi_d * _exprel(1j * phi)
    # p: the dual admittances g/n², all scaled by η1² (r is homogeneous of degree 0 in (Y, 1/W)), so that a
    # medium matching the ambient keeps Y = g exactly: g/η1² underflows to 0 for a subnormal cos θ1 and
    # left 0/0 where both Y1 and Y3 did (η3 = η1, d = 0, cos θ1 = 5e-324).
    terms = {
        "s": (g1, g2, g3, w_s),
        "p": (g1, g2 * (e1 / e2) ** 2, g3 * (e1 * e1 / n3**2), w_s * (e2 / e1) ** 2),
    }
    return terms, phi, c1


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num/den for complex arrays, scaled first: numpy's complex division
    overflows to inf + nan·i when both are subnormal (cos θ1 ~ 1e-320)."""
    scale = np.maximum(np.abs(np.real(den)), np.abs(np.imag(den)))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):

        def scaled(z: np.ndarray) -> np.ndarray:  # real divisions: numpy's complex path overflows here too
            out = np.empty(np.broadcast_shapes(np.shape(z), scale.shape), complex)
            np.divide(np.real(z), scale, out=out.real)
            np.divide(np.imag(z), scale, out=out.imag)
            return out

        return scaled(num) / scaled(den)


def _airy_amplitude(
    y1: np.ndarray, y2: np.ndarray, y3: np.ndarray, w: np.ndarray, cos_theta1: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(r, num, den): the Airy amplitude r = num/den of the module docstring."""
    num = 2.0 * (y1 - y3) + (y1 + y2) * (y2 - y3) * w
    den = 2.0 * (y1 + y3) + (y1 - y2) * (y2 - y3) * w
    r = _ratio(num, den)
    # Grazing incidence: every stack reflects totally (r → −1); this also
    # settles 0/0 when all three admittances vanish together.
    return np.where(cos_theta1 == 0.0, -1.0 + 0j, r), num, den


def _transmitted_power(
    y1: np.ndarray, y3: np.ndarray, den: np.ndarray, phi: np.ndarray, cos_theta1: np.ndarray
) -> np.ndarray:
    """Power into the base, 16·Re(Y1)·Re(Y3)·e^{−Im Φ}/|den|² (a product of terms ≥ 0),
    formed as |4·√Re Y1·√Re Y3·e^{−Im Φ/2}/den|² so tiny admittances cannot underflow."""
    amplitude = 4.0 * np.sqrt(y1.real) * np.sqrt(np.maximum(y3.real, 0.0)) * np.exp(-0.5 * phi.imag)
    t = np.abs(_ratio(amplitude + 0j, den)) ** 2
    return np.where(cos_theta1 == 0.0, 0.0, t)


def _terms(stack: FilmPoints, wavelength_nm: ArrayLike) -> tuple[_Terms, np.ndarray, np.ndarray]:
    """``_stack_terms`` of the stack at ``wavelength_nm`` (named materials taken there; constant indices
    left unbroadcast, so the admittances are computed per point)."""
    named = stack.film is not None or stack.base is not None
    eta2, eta3, kappa3 = stack.indices(wavelength_nm) if named else (stack.eta2, stack.eta3, stack.kappa3)
    return _stack_terms(stack.eta1, eta2, eta3, kappa3, stack.cos_theta, stack.thickness_nm, wavelength_nm)


def film_amplitudes(stack: FilmPoints, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Complex reflected amplitudes (r_s, r_p) of the film stack at ``wavelength_nm`` (broadcast)."""
    terms, _, c1 = _terms(stack, wavelength_nm)
    r_s, r_p = (_airy_amplitude(*terms[pol], c1)[0] for pol in ("s", "p"))
    return r_s, r_p


def _reflected_power(
    y1: np.ndarray, y3: np.ndarray, r: np.ndarray, den: np.ndarray, phi: np.ndarray, cos_theta1: np.ndarray
) -> np.ndarray:
    """|r|² where it is ≤ 1/2, else 1 − T, the power into the base computed only there (NaN included, as a
    np.where over both branches took it)."""
    power = np.asarray(np.abs(r) ** 2)  # complex division scales, so tiny admittances cannot underflow
    high = ~(power <= 0.5)
    if high.any():
        at_high = [np.broadcast_to(a, power.shape)[high] for a in (y1, y3, den, phi, cos_theta1)]
        power[high] = 1.0 - _transmitted_power(*at_high)
    return power


def film_reflectance(stack: FilmPoints, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Reflectances (R_s, R_p, R) with R = (R_s + R_p)/2 (unpolarized), the stack's fields broadcast
    against ``wavelength_nm`` (``stack.as_column()`` against a row of M wavelengths gives (P, M)).

    Where |r|² ≤ 1/2 it is |num|²/|den|²; above, 1 − T with T the power
    into the base (the film is lossless, so R + T = 1 exactly). Both are
    ratios of non-negative terms, so 0 ≤ R ≤ 1 holds by construction and
    1 − R keeps its relative accuracy near total reflection.
    """
    terms, phi, c1 = _terms(stack, wavelength_nm)
    out = []
    for pol in ("s", "p"):
        y1, _, y3, _ = terms[pol]
        r, _, den = _airy_amplitude(*terms[pol], c1)
        out.append(_reflected_power(y1, y3, r, den, phi, c1))
    return out[0], out[1], 0.5 * (out[0] + out[1])


def film_transmittance(stack: FilmPoints, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Power transmitted into the base, (T_s, T_p, T), broadcast as ``film_reflectance``.

    T = 16·Re(Y1)·Re(Y3)·e^{−Im Φ} / |den|², Macleod's 4·Re(Y1)Re(Y3)/|Y1B + C|²
    rewritten for the normalized denominator above. With a lossless film,
    R + T = 1 holds for any base (the base absorbs what it transmits).
    """
    terms, phi, c1 = _terms(stack, wavelength_nm)
    out = []
    for pol in ("s", "p"):
        y1, _, y3, _ = terms[pol]
        den = _airy_amplitude(*terms[pol], c1)[2]
        out.append(_transmitted_power(y1, y3, den, phi, c1))
    return out[0], out[1], 0.5 * (out[0] + out[1])


def round_trip_amplitude(
    eta1: ArrayLike, eta2: ArrayLike, eta3: ArrayLike, kappa3: ArrayLike, cos_theta1: ArrayLike
) -> np.ndarray:
    """max over s, p of |r21·r23|, the Airy sum's ratio: its peaks sharpen as it nears 1."""
    terms, _, _ = _stack_terms(eta1, eta2, eta3, kappa3, cos_theta1, 0.0, 500.0)
    out = 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        for y1, y2, y3, _ in terms.values():
            ratio = np.abs((y1 - y2) / (y1 + y2) * (y2 - y3) / (y2 + y3))
            out = np.maximum(out, np.nan_to_num(ratio, nan=0.0))
    return np.minimum(out, 1.0)
