"""The spectral integral in closed form by the poles of the Airy series: no slow series, no quadrature.

Per polarization the Fourier series of lutbake/spectral/fourier.py sums (docs/spectral.md)::

    I_c = Σ_{m≥1} K q^{m−1} Ŵ_c(m X) = ∫ w_c(λ) f(λ) dλ,   f(λ) = K z/(1 − q z),   z = e^{i2πX/λ},

whose terms fall only as |q|^m: slowly where the film rings (|q| → 1, metals near grazing incidence).
As a function of complex λ, f has simple poles where q z = 1,

    P_n = 1/p_n,   p_n = ζ + n/X,   ζ = i log(q)/(2πX)   (n ∈ ℤ, Im P_n > 0),
    residue R_n = (K/q) P_n²/(i2πX),   and   f(λ) = K/(1 − q) + Σ_n R_n/(λ − P_n)

(the Mittag-Leffler expansion of the cotangent, summed symmetrically). The poles near the visible band
make f sharp there; subtracting them (those inside the Bernstein ellipse E_3 of [360, 830] nm) leaves
h = f − Σ_near R_n/(λ − P_n), analytic inside E_3, so

    I_c = Σ_near R_n Γ_c(P_n) + ∫ w_c h dλ,      Γ_c(P) = ∫ w_c(λ)/(λ − P) dλ.

Γ_c, the Cauchy transform of the colour weights, does not depend on the film: ``CauchyTable`` tabulates
it with an a-priori bound. The second integral is a product rule on Chebyshev points (``chebyshev_rule``:
the weights integrate w_c exactly against the interpolant), whose error is at most
∫|w_c| · 4 M ρ^{−n}/(ρ − 1) for |h| ≤ M on E_ρ (Trefethen, *Approximation Theory and Approximation
Practice*, Thm 8.2); ``closed_form`` bounds M from the far poles. The result is exact up to those two
stated bounds, at a cost that does not grow as |q| → 1: one table read per near pole and 41 nodes.

Γ_c in closed form: w_c is linear between the 1 nm samples k (colorimetry), so on each panel
∫ (α + βλ)/(λ − P) dλ = β + (α + βP)[log(k + 1 − P) − log(k − P)], and summed by knot

    Γ_c(P) = G_c + Σ_{k=360}^{830} (A_ck + B_ck P) log(k − P),

with B_ck the jump of w_c's slope at k (and the edges, where w_c itself jumps to 0). ``CauchyTable``
keeps, per 1 nm cell along the band, the Taylor series of all but the 2L nearest knots (L = 4, evaluated
exactly) for P within 1 nm of the real axis, where those knots make Γ_c kink; deeper in the upper half
plane Γ_c is smooth on the scale of its depth y, and levels of cells y/2 wide (depth in [2^ℓ, 2^{ℓ+1}) nm)
keep its Taylor series about their centres. Every Taylor truncation is bounded a priori from the knot
coefficients (Σ_k |coefficient| t^{d+1}/((d+1)(1 − t)), t = radius / distance to knot k).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from lutbake.io.usercache import cached_arrays
from lutbake.physics.colorimetry import WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, colorimetry

__all__ = [
    "CauchyTable",
    "cauchy_table",
    "ChebyshevRule",
    "chebyshev_rule",
    "ClosedForm",
    "closed_form",
    "bernstein_rho",
    "NEAR_RHO",
    "BOUND_RHO",
    "CHEBYSHEV_DEGREE",
    "MAX_NEAR_POLES",
    "MAX_WINDOW",
    "DEEP_LIMIT_NM",
    "WINDOW_NU_PER_NM",
]

BAND_CENTRE_NM = 0.5 * (WAVELENGTH_MIN_NM + WAVELENGTH_MAX_NM)
BAND_HALF_NM = 0.5 * (WAVELENGTH_MAX_NM - WAVELENGTH_MIN_NM)
NEAR_RHO = 3.0  # poles inside this Bernstein ellipse of the band are subtracted
BOUND_RHO = 2.5  # the ellipse on which |h| is bounded (inside E_3, outside the band)
CHEBYSHEV_DEGREE = 40  # 41 nodes: ρ^{−n} = 1.2e-16 at ρ = 2.5
MAX_NEAR_POLES = 32  # more (films thicker than ~6 µm) go to the direct quadrature
MAX_WINDOW = 256  # poles enumerated per texel at most (X up to ~25 µm; more: direct quadrature)
N_KNOTS = int(WAVELENGTH_MAX_NM - WAVELENGTH_MIN_NM) + 1  # the 1 nm samples of the weights
# Table geometry: Re P in [200, 990) nm covers E_3 ([203, 987]); depth below 1 nm is "shallow" (knots
# within L of P exact), deeper cells are levels 2^ℓ ≤ Im P < 2^{ℓ+1} nm up to 512 nm (E_3 reaches 313).
RE_MIN_NM, RE_MAX_NM = 200.0, 990.0
SHALLOW_NM = 1.0
NEAR_KNOTS = 4
SHALLOW_DEGREE, DEEP_DEGREE = 16, 22
DEEP_LEVELS = 9
DEEP_LIMIT_NM = SHALLOW_NM * 2.0**DEEP_LEVELS
# Poles p_n with Re p_n in this window (1/nm) are enumerated: it holds every pole inside E_3
# (Re p ∈ [1.9e-4, 4.93e-3]); the tail outside it is bounded in closed form (_far_tail).
WINDOW_NU_PER_NM = (-2e-3, 8e-3)


def bernstein_rho(P: npt.ArrayLike) -> np.ndarray:
    """ρ ≥ 1 of the Bernstein ellipse of [360, 830] nm through P (foci at the band's ends)."""
    w = (np.asarray(P, complex) - BAND_CENTRE_NM) / BAND_HALF_NM
    s = np.sqrt(w * w - 1.0)
    return np.maximum(np.abs(w + s), np.abs(w - s))


def _semi_major(rho: np.ndarray | float) -> np.ndarray | float:
    """Semi-major axis (nm) of E_ρ."""
    return BAND_HALF_NM * 0.5 * (rho + 1.0 / rho)


@dataclass(frozen=True)
class CauchyTable:
    """Γ_c(P) = ∫ w_c(λ)/(λ − P) dλ for Im P > 0, 200 ≤ Re P < 990 nm, Im P < 512 nm.

    ``knot_a``, ``knot_b`` (3, 471): Γ_c = ``constant``_c + Σ_k (a_ck + b_ck P) log(k − P) over the
    knots k = 360 … 830 nm. ``shallow`` (cells, 3, SHALLOW_DEGREE + 1): per 1 nm cell j (Re P in
    [j, j + 1), Im P < 1 nm) the Taylor coefficients in P − (j + ½) of Γ_c minus its knots j − 3 … j + 4.
    ``deep`` (cells, 3, DEEP_DEGREE + 1): Taylor coefficients about each deep cell's centre.
    ``bound`` (3,): a-priori bound on |table − Γ_c| anywhere in the domain.
    """

    knot_a: np.ndarray
    knot_b: np.ndarray
    constant: np.ndarray
    shallow: np.ndarray
    deep: np.ndarray
    bound: np.ndarray

    def __call__(self, pole: npt.ArrayLike) -> np.ndarray:
        """Γ_c at P = ``pole`` (any shape, Im P > 0, inside the table's domain): (3, *P.shape) complex."""
        P = np.asarray(pole, complex)
        if np.any((P.imag <= 0) | (P.imag >= DEEP_LIMIT_NM) | (P.real < RE_MIN_NM) | (P.real >= RE_MAX_NM)):
            raise ValueError("P outside the Cauchy table's domain")
        flat = P.ravel()
        out = np.empty((3, flat.size), complex)
        shallow = flat.imag < SHALLOW_NM
        out[:, shallow] = self._shallow(flat[shallow])
        out[:, ~shallow] = self._deep(flat[~shallow])
        return out.reshape((3,) + P.shape)

    def _shallow(self, P: np.ndarray) -> np.ndarray:
        j = np.floor(P.real).astype(np.int64)
        coef = self.shallow[j - int(RE_MIN_NM)]  # (n, 3, d + 1)
        out = _horner(coef, P - (j + 0.5))
        for offset in range(1 - NEAR_KNOTS, NEAR_KNOTS + 1):
            k = j + offset
            inside = (k >= WAVELENGTH_MIN_NM) & (k <= WAVELENGTH_MAX_NM)
            i = np.clip(k - int(WAVELENGTH_MIN_NM), 0, self.knot_a.shape[1] - 1)
            term = (self.knot_a[:, i] + self.knot_b[:, i] * P) * np.log(k - P)
            out += np.where(inside, term, 0.0)
        return out

    def _deep(self, P: np.ndarray) -> np.ndarray:
        cell, centre = deep_cell(P)
        return _horner(self.deep[cell], P - centre)


def _horner(coef: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Σ_m coef[..., m] u^m for coef (n, 3, d + 1), u (n,): (3, n)."""
    out = coef[:, :, -1].T.copy()
    for m in range(coef.shape[2] - 2, -1, -1):
        out = out * u + coef[:, :, m].T
    return out


def _deep_levels() -> tuple[np.ndarray, np.ndarray]:
    """(columns, first cell) of each deep level: two rows of cells 2^ℓ/2 nm wide."""
    cols = [int(np.ceil((RE_MAX_NM - RE_MIN_NM) / (0.5 * SHALLOW_NM * 2.0**level))) for level in range(DEEP_LEVELS)]
    first = np.concatenate([[0], np.cumsum([2 * c for c in cols])])
    return np.array(cols), first


def deep_cell(pole: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(cell index, centre) of the deep cell holding each P = ``pole`` (Im P ≥ 1 nm)."""
    P = np.asarray(pole, complex)
    cols, first = _deep_levels()
    level = np.clip(np.floor(np.log2(P.imag / SHALLOW_NM)).astype(np.int64), 0, DEEP_LEVELS - 1)
    depth = SHALLOW_NM * 2.0**level
    width = 0.5 * depth
    row = (P.imag >= 1.5 * depth).astype(np.int64)
    col = np.clip(np.floor((P.real - RE_MIN_NM) / width).astype(np.int64), 0, cols[level] - 1)
    centre = RE_MIN_NM + (col + 0.5) * width + 1j * depth * (1.25 + 0.5 * row)
    return first[level] + row * cols[level] + col, centre


def _knots(table: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, constant) of Γ = constant + Σ_k (a_k + b_k P) log(k − P) for a (3, 471) table at 1 nm."""
    slope = np.diff(table, axis=1)  # per panel [k, k + 1)
    intercept = table[:, :-1] - slope * np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)
    zero = np.zeros((3, 1))
    slope_pad, intercept_pad = np.hstack([zero, slope, zero]), np.hstack([zero, intercept, zero])
    # knot k collects panel k−1's linear function minus panel k's (outside the band: 0)
    return intercept_pad[:, :-1] - intercept_pad[:, 1:], slope_pad[:, :-1] - slope_pad[:, 1:], slope.sum(axis=1)


def _taylor(
    a: np.ndarray,
    b: np.ndarray,
    knots: np.ndarray,
    centres: np.ndarray,
    use: np.ndarray,
    degree: int,
    radius: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Taylor coefficients (C, 3, degree + 1) about each of C ``centres`` of Σ_{k in use} (a_k + b_k P)
    log(k − P) (``use`` (C, knots) boolean), and the bound (3,) on the dropped terms for
    |P − c| ≤ radius, the largest over the centres.

    With d = k − c and u = P − c, log(k − P) = log d − Σ_m (u/d)^m/m (the branch P in the upper half
    plane sees: arg d = −π for knots left of a real centre), so the coefficient of u^m is
    −Σ_k [(a_k + b_k c)/(m d^m) + b_k/((m − 1) d^{m−1})] (m ≥ 2): sums over knots as matrix products."""
    diff = knots[None, :] - centres[:, None]  # (C, K)
    if np.all(np.imag(centres) == 0):
        log0 = np.log(np.abs(diff)) - 1j * np.pi * (np.real(diff) < 0)
    else:
        log0 = np.log(diff.astype(complex))
    inverse = np.where(use, 1.0 / diff, 0.0)

    def knot_sum(weights: np.ndarray, values: np.ndarray) -> np.ndarray:  # (3, K) real × (C, K) → (3, C)
        return (np.ascontiguousarray(values) @ weights.T.astype(complex)).T

    def alpha_sum(values: np.ndarray) -> np.ndarray:  # Σ_k (a_k + b_k c) values
        return knot_sum(a, values) + centres[None, :] * knot_sum(b, values)

    logs = np.where(use, log0, 0.0)
    coef = np.empty((3, centres.size, degree + 1), complex)
    coef[..., 0] = alpha_sum(logs)
    coef[..., 1] = knot_sum(b, logs) - alpha_sum(inverse)
    previous, power = inverse, inverse * inverse
    for m in range(2, degree + 1):
        coef[..., m] = -alpha_sum(power) / m - knot_sum(b, previous) / (m - 1)
        previous, power = power, power * inverse
    t = radius * np.abs(inverse)  # 0 where not used
    tail_a = t ** (degree + 1) / ((degree + 1) * (1 - t))
    tail_b = radius * t**degree / (degree * (1 - t))
    alpha = np.abs(a[:, None, :] + b[:, None, :] * centres[None, :, None])  # |a_k + b_k c|, (3, C, K)
    bound = (alpha * tail_a[None]).sum(axis=2) + np.abs(b) @ tail_b.T
    return coef.transpose(1, 0, 2), bound.max(axis=1)


def _build_tables(table: np.ndarray) -> dict[str, np.ndarray]:
    a, b, constant = _knots(table)
    knots = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM + 0.5)
    cells = np.arange(RE_MIN_NM, RE_MAX_NM)
    far = (knots[None] < cells[:, None] + 1 - NEAR_KNOTS) | (knots[None] > cells[:, None] + NEAR_KNOTS)
    shallow, bound = _taylor(a, b, knots, cells + 0.5, far, SHALLOW_DEGREE, float(np.hypot(0.5, SHALLOW_NM)))
    cols, first = _deep_levels()
    deep = np.empty((first[-1], 3, DEEP_DEGREE + 1), complex)
    for level in range(DEEP_LEVELS):
        depth = SHALLOW_NM * 2.0**level
        for row in range(2):
            centres = RE_MIN_NM + (np.arange(cols[level]) + 0.5) * 0.5 * depth + 1j * depth * (1.25 + 0.5 * row)
            start = first[level] + row * cols[level]
            deep[start : start + cols[level]], b_cells = _taylor(
                a,
                b,
                knots,
                centres,
                np.ones((centres.size, knots.size), bool),
                DEEP_DEGREE,
                float(np.hypot(0.25 * depth, 0.25 * depth)),
            )
            bound = np.maximum(bound, b_cells)
    shallow[:, :, 0] += constant
    deep[:, :, 0] += constant
    return {"a": a, "b": b, "constant": constant, "shallow": shallow, "deep": deep, "bound": bound}


@functools.lru_cache(maxsize=1)
def _construction_digest() -> bytes:
    source = "".join(inspect.getsource(f) for f in (_knots, _taylor, _build_tables, _deep_levels))
    constants = (RE_MIN_NM, RE_MAX_NM, SHALLOW_NM, NEAR_KNOTS, SHALLOW_DEGREE, DEEP_DEGREE, DEEP_LEVELS)
    return hashlib.sha256(f"{source}{constants}".encode()).digest()


@functools.lru_cache(maxsize=8)
def cauchy_table(observer: str = "cie1931", space: str = "rec709", basis: str = "rgb") -> CauchyTable:
    """The Cauchy transform table of one (observer, space, basis), built once per machine (~4 s, 8 MB;
    kept in the user cache)."""
    cm = colorimetry(observer, space)
    table = cm.rgb_table if basis == "rgb" else cm.xyz_table
    n_deep = int(_deep_levels()[1][-1])
    shapes = {
        "a": (3, table.shape[1]),
        "b": (3, table.shape[1]),
        "constant": (3,),
        "shallow": (int(RE_MAX_NM - RE_MIN_NM), 3, SHALLOW_DEGREE + 1),
        "deep": (n_deep, 3, DEEP_DEGREE + 1),
        "bound": (3,),
    }
    arrays = cached_arrays("cauchy", _construction_digest() + table.tobytes(), shapes, lambda: _build_tables(table))
    return CauchyTable(arrays["a"], arrays["b"], arrays["constant"], arrays["shallow"], arrays["deep"], arrays["bound"])


@dataclass(frozen=True)
class ChebyshevRule:
    """Chebyshev points of the second kind on [360, 830] nm and weights (3, n + 1) with
    Σ_i weights[c, i] g(λ_i) = ∫ w_c(λ) p(λ) dλ, p the degree-n interpolant of g."""

    wavelength_nm: np.ndarray
    weights: np.ndarray
    mass: np.ndarray  # ∫ |w_c| dλ


@functools.lru_cache(maxsize=8)
def chebyshev_rule(
    observer: str = "cie1931", space: str = "rec709", basis: str = "rgb", degree: int = CHEBYSHEV_DEGREE
) -> ChebyshevRule:
    """Product-integration weights: the Chebyshev moments μ_k = ∫ w_c T_k dλ by Gauss–Legendre on
    every 1 nm panel (exact: w_c is linear there), then the discrete Chebyshev transform."""
    cm = colorimetry(observer, space)
    x = np.cos(np.pi * np.arange(degree + 1) / degree)
    gx, gw = np.polynomial.legendre.leggauss(degree // 2 + 2)
    lam = (np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)[:, None] + 0.5 * (gx[None] + 1.0)).ravel()
    weighted = cm.sensitivity(lam, basis) * np.tile(0.5 * gw, int(WAVELENGTH_MAX_NM - WAVELENGTH_MIN_NM))
    t = np.arccos(np.clip((lam - BAND_CENTRE_NM) / BAND_HALF_NM, -1.0, 1.0))
    moments = weighted @ np.cos(np.outer(t, np.arange(degree + 1)))  # (3, degree + 1)
    halve = np.ones(degree + 1)
    halve[[0, -1]] = 0.5
    basis_at_nodes = np.cos(np.outer(np.arccos(x), np.arange(degree + 1)))  # T_k(x_i)
    weights = (2.0 / degree) * halve[None, :] * ((moments * halve[None, :]) @ basis_at_nodes.T)
    return ChebyshevRule(
        BAND_CENTRE_NM + BAND_HALF_NM * x, weights, _mass(cm.rgb_table if basis == "rgb" else cm.xyz_table)
    )


def _mass(table: np.ndarray) -> np.ndarray:
    """∫|w_c| dλ, exactly, for the piecewise-linear table (3, 471) on 1 nm panels (split where w_c crosses 0)."""
    w0, w1 = np.abs(table[:, :-1]), np.abs(table[:, 1:])
    same = np.sign(table[:, :-1]) * np.sign(table[:, 1:]) >= 0
    with np.errstate(invalid="ignore", divide="ignore"):
        crossing = (w0**2 + w1**2) / (2 * (w0 + w1))
    return np.where(same, 0.5 * (w0 + w1), crossing).sum(axis=1)


@dataclass
class ClosedForm:
    """Per texel-polarization: I_c (n, 3) complex, the a-priori bound on |ΔI| (n,), and whether the
    closed form applies (``ok``: at most MAX_NEAR_POLES poles near the band; else the direct path)."""

    integral: np.ndarray | None  # None: not integrated (``closed_form(..., integrate=False)``)
    bound: np.ndarray
    ok: np.ndarray
    near_poles: np.ndarray


def _far_tail(X: np.ndarray, k_over_q: np.ndarray) -> np.ndarray:
    """Bound on Σ |R_n|/dist(P_n, E_BOUND_RHO) over the poles outside the enumerated window.

    Outside it |Re p_n| ≥ 2e-3 (left: Re P ≤ 0 or P beyond 500 nm of 0) or Re p_n ≥ 8e-3 (right:
    |P_n| ≤ 125 nm), so every such P_n lies at least 129 nm from E_2.5 (its left vertex is at 254 nm)
    and |P_n| ≤ 1/|Re p_n|. With the Re p_n spaced 1/X apart from |Re p| ≥ 2e-3 on,
    Σ 1/(Re p_n)² ≤ 2 (1/(2e-3)² + X/2e-3), and |R_n| = |K/q| |P_n|²/(2πX)."""
    return np.abs(k_over_q) / (2 * np.pi * X * 129.0) * 2.0 * (1.0 / 2e-3**2 + X / 2e-3)


def _node_values(
    k_over_q: np.ndarray,
    X: np.ndarray,
    P_near: np.ndarray,
    R_near: np.ndarray,
    near: np.ndarray,
    lam: np.ndarray,
    reference: np.ndarray,
) -> np.ndarray:
    """h at the Chebyshev nodes (n, nodes): f minus the near poles' terms, f evaluated relative to the
    node's nearest near pole P* (or ``reference``, a pole, where none is near), so no rounding of the
    phase 2πX/λ is amplified near a pole: q z = e^{iθ}, θ = 2πX (P* − λ)/(λ P*) exactly, and
    f − R*/(λ − P*) = (K/q) [−1 − (1/(e^{iθ} − 1) − 1/(iθ)) + P*/(i2πX)]."""
    dist = np.where(near[:, None, :], np.abs(P_near[:, None, :] - lam[None, :, None]), np.inf)  # (n, nodes, W)
    nearest = np.argmin(dist, axis=2)
    has_near = np.isfinite(np.take_along_axis(dist, nearest[..., None], 2)[..., 0])
    star = np.where(has_near, np.take_along_axis(P_near, nearest, 1), reference[:, None])
    theta = 2 * np.pi * X[:, None] * (star - lam[None]) / (lam[None] * star)
    x = 1j * theta
    with np.errstate(divide="ignore", invalid="ignore"):
        direct = 1.0 / np.expm1(x) - 1.0 / x
    small = np.abs(x) < 0.05
    series = -0.5 + x / 12 - x**3 / 720 + x**5 / 30240 - x**7 / 1209600
    g = np.where(small, series, direct)
    pole_term = np.where(has_near, star / (2j * np.pi * X[:, None]), 0.0)
    # without a near pole, f itself: (K/q)(−1 − 1/(e^{iθ} − 1)) = (K/q)(−1 − g − 1/(iθ))
    with np.errstate(divide="ignore", invalid="ignore"):
        inverse = np.where(has_near, 0.0, 1.0 / x)
    h = k_over_q[:, None] * (-1.0 - g - inverse + pole_term)
    others = R_near[:, None, :] / (lam[None, :, None] - P_near[:, None, :])
    is_star = np.arange(P_near.shape[1])[None, None, :] == nearest[..., None]
    others = np.where(near[:, None, :] & ~(is_star & has_near[..., None]), others, 0.0)
    return h - others.sum(axis=2)


def closed_form(
    k: npt.ArrayLike,
    q: npt.ArrayLike,
    x_nm: npt.ArrayLike,
    observer: str = "cie1931",
    space: str = "rec709",
    integrate: bool = True,
) -> ClosedForm:
    """I_c = Σ_m K q^{m−1} Ŵ_c(mX) by the poles (module docstring), for flat arrays K, q (|q| < 1,
    q ≠ 0) and X > 0 of n texel-polarizations, in float64, a chunk of texels at a time (memory stays
    bounded); ``integrate=False`` gives the rule's outcome and bound alone (``integral`` None)."""
    k, q, X = (np.atleast_1d(np.asarray(v)) for v in (k, q, x_nm))
    X = X.astype(float)
    n = k.size
    integral, bound, count = np.zeros((n, 3), complex), np.full(n, np.inf), np.zeros(n, np.int64)
    start = 0
    while start < n:
        # a chunk whose pole windows × nodes stay within 2^18 values
        width = _window_width(q[start : start + 4096], X[start : start + 4096])
        end = start + max(1, min(4096, (1 << 18) // ((CHEBYSHEV_DEGREE + 1) * max(1, width))))
        part = slice(start, end)
        integral[part], bound[part], count[part] = _closed_form(k[part], q[part], X[part], observer, space, integrate)
        start = end
    ok = np.isfinite(bound)
    return ClosedForm(integral if integrate else None, bound, ok, count)


def _window(q: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First and last n of each texel's enumerated poles (Re p_n within WINDOW_NU_PER_NM), and ζ."""
    zeta = 1j * np.log(q) / (2 * np.pi * X)
    return np.floor(X * (WINDOW_NU_PER_NM[0] - zeta.real)), np.ceil(X * (WINDOW_NU_PER_NM[1] - zeta.real)), zeta


def _window_width(q: np.ndarray, X: np.ndarray) -> int:
    n_lo, n_hi, _ = _window(q, X)
    return int(min(MAX_WINDOW, (n_hi - n_lo).max(initial=0) + 1))


def _closed_form(
    k: np.ndarray, q: np.ndarray, X: np.ndarray, observer: str, space: str, integrate: bool
) -> tuple[np.ndarray | float, np.ndarray, np.ndarray]:
    """(integral (n, 3), bound (n,) (inf where the closed form does not apply), near poles (n,))."""
    table, rule = cauchy_table(observer, space), chebyshev_rule(observer, space)
    n_lo, n_hi, zeta = _window(q, X)
    width = _window_width(q, X)
    n = n_lo[:, None] + np.arange(width)[None]
    valid = n <= n_hi[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        P = 1.0 / (zeta[:, None] + n / X[:, None])
    rho = np.where(valid, bernstein_rho(P), np.inf)
    near = valid & (rho < NEAR_RHO)
    k_over_q = k / q
    R = k_over_q[:, None] * P**2 / (2j * np.pi * X[:, None])
    count = near.sum(axis=1)
    ok = (count <= MAX_NEAR_POLES) & (n_hi - n_lo + 1 <= MAX_WINDOW)
    # |h| on E_2.5: K/(1 − q) plus every far pole's |R|/distance (confocal ellipses are at least the
    # difference of their semi-major axes apart), the window explicitly, the rest by _far_tail
    far = valid & ~near
    with np.errstate(divide="ignore", invalid="ignore"):
        gap = np.where(far, _semi_major(rho) - _semi_major(BOUND_RHO), np.inf)
        explicit = np.where(far, np.abs(R) / gap, 0.0).sum(axis=1)
    M = np.abs(k / (1 - q)) + explicit + _far_tail(X, k_over_q)
    R_near = np.where(near, R, 0.0)
    bound = (
        rule.mass.max() * 4 * M * BOUND_RHO ** (-CHEBYSHEV_DEGREE) / (BOUND_RHO - 1)
        + np.abs(R_near).sum(axis=1) * table.bound.max()
    )
    bound = np.where(ok, bound, np.inf)
    if not integrate:
        return 0.0, bound, count
    P_near = np.where(near, P, 1j * BAND_HALF_NM + BAND_CENTRE_NM)  # a harmless placeholder
    integral = np.einsum("cnw,nw->nc", table(P_near), R_near)
    # the reference pole for texels without a near pole: the window's pole closest to the band's centre
    closest = np.argmin(np.where(valid, np.abs(1.0 / np.where(valid, P, 1.0) - 1.0 / BAND_CENTRE_NM), np.inf), 1)
    reference = np.take_along_axis(P, closest[:, None], 1)[:, 0]
    h = _node_values(k_over_q, X, P_near, R_near, near, rule.wavelength_nm, reference)
    return integral + h @ rule.weights.T, bound, count
