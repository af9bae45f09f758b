"""Exact Fourier-series integration of the Airy reflectance against the colour weights.

With constant indices each polarization's amplitude is a Möbius function of
z = e^{iΦ}, Φ = 2π·X·ν, X = D·cos θ2 (docs/spectral.md derives it)::

    r = (a + b z)/(1 + a b z) = a + γ Σ_{m≥1} q^{m−1} z^m,   q = −a b,  γ = b (1 − a²)
    |r|² = C0 + 2 Re Σ_{m≥1} K q^{m−1} z^m,
    C0 = |a|² + |γ|²/(1 − |q|²),   K = γ ā + q |γ|²/(1 − |q|²)

with a = r12, b = r23 (|z| = 1: a real, non-evanescent film). Integrating
term by term against the colour weights w_c gives, per polarization,

    ∫ w_c |r|² dλ = C0 Ŵ_c(0) + 2 Re Σ_m K q^{m−1} Ŵ_c(m X),   Ŵ_c(x) = ∫ w_c(λ) e^{i2πx/λ} dλ.

``WeightTransform`` tabulates Ŵ_c from exactly the weights the ground truth
integrates (colorimetry's piecewise-linear CMF × illuminant on 1 nm panels),
demodulated by e^{i2πxν0} so the table is smooth, as quintic Hermite pieces
with a stated a-priori error bound; past the table it bounds |Ŵ_c| by the
1/x + 1/x² decay from integrating by parts twice. ``series_colour`` is the
float64 numpy implementation of the series and of the per-texel rule that
picks it over the direct quadrature (the bake kernel runs the same rule).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.io.usercache import cached_arrays
from lutbake.physics.colorimetry import WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, colorimetry
from lutbake.physics.optics import _stack_terms, normal_admittance

if TYPE_CHECKING:
    from lutbake.physics.points import FilmPoints

__all__ = [
    "WeightTransform",
    "weight_transform",
    "SeriesCoefficients",
    "series_coefficients",
    "SeriesResult",
    "series_colour",
    "series_plan",
    "PATHS",
    "NU0_PER_NM",
    "NU_HALF_BAND_PER_NM",
    "TABLE_STEP_NM",
    "TABLE_MAX_NM",
    "SERIES_BUDGET",
    "DEFAULT_SERIES_TOLERANCE",
]

NU_MIN_PER_NM = 1.0 / WAVELENGTH_MAX_NM
NU_MAX_PER_NM = 1.0 / WAVELENGTH_MIN_NM
NU0_PER_NM = 0.5 * (NU_MIN_PER_NM + NU_MAX_PER_NM)  # demodulation: centre of the support in ν
NU_HALF_BAND_PER_NM = 0.5 * (NU_MAX_PER_NM - NU_MIN_PER_NM)  # the support's half width: |ν − ν0| ≤ this
TABLE_STEP_NM = 25.0
TABLE_MAX_NM = 4.0e5
DEFAULT_SERIES_TOLERANCE = 1e-9  # per polarization: truncation bound on the dropped terms
SERIES_BUDGET = 512  # most terms a texel's series may take before the direct path is cheaper
_NODES_PER_RADIAN = 3.0
_X_BLOCK = 512


@dataclass(frozen=True)
class WeightTransform:
    """Ŵ_c(x) for one (observer, space, basis), 0 ≤ x ≤ x_max, and bounds on it.

    ``coefficients`` (intervals, 3, 6) complex: on [k h, (k+1) h] the
    demodulated transform is Σ_j c_j t^j, t = x/h − k (quintic Hermite
    through the exact value, first and second derivative at both ends).
    """

    step_nm: float
    coefficients: np.ndarray
    mass: np.ndarray  # ∫|w_c| dλ: |Ŵ_c(x)| ≤ mass_c for every x
    edge: np.ndarray  # |w̃_c| at both ends of the ν support (the 1/x term)
    variation: np.ndarray  # |w̃_c'| at both ends + total variation of w̃_c' (the 1/x² term)
    interpolation_bound: np.ndarray  # per channel: sup |table − Ŵ_c| (a priori)

    @property
    def x_max_nm(self) -> float:
        return self.step_nm * self.coefficients.shape[0]

    def __call__(self, x_nm: npt.ArrayLike) -> np.ndarray:
        """Ŵ_c(x), shape (3, *x.shape), from the table (x in [0, x_max])."""
        x = np.asarray(x_nm, float)
        if np.any((x < 0) | (x > self.x_max_nm)):
            raise ValueError(f"x outside the table's [0, {self.x_max_nm:g}] nm")
        s = x / self.step_nm
        k = np.minimum(s.astype(np.int64), self.coefficients.shape[0] - 1)
        t = (s - k)[None]
        c = np.moveaxis(self.coefficients[k], (-2, -1), (0, 1))  # (3, 6, *x.shape)
        value = c[:, 5]
        for j in range(4, -1, -1):
            value = value * t + c[:, j]
        return value * np.exp(2j * np.pi * NU0_PER_NM * x)[None]

    def tail_bound(self, x_nm: npt.ArrayLike) -> np.ndarray:
        """Bound on |Ŵ_c(y)| for every channel and every y ≥ x (x > 0), from the largest
        channel's constants (one bound, so the kernel's rule loop stays cheap)."""
        x = 2.0 * np.pi * np.asarray(x_nm, float)
        with np.errstate(divide="ignore"):
            decay = (self.edge.max() + self.variation.max() / x) / x
        return np.minimum(self.mass.max(), decay)


def _panel_nodes(x_max_nm: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes λ (nm) and dλ weights on every 1 nm panel of the weight table.

    e^{i2πx/λ} turns x/λ² times per nm: each panel gets nodes in proportion
    (3 per radian at x_max, at least 8), which integrates it to rounding.
    """
    left = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)
    counts = np.maximum(8, np.ceil(_NODES_PER_RADIAN * np.pi * x_max_nm / left**2)).astype(int)
    lam_parts, quad_parts = [], []
    for n in np.unique(counts):
        x, w = np.polynomial.legendre.leggauss(n)
        edges = left[counts == n]
        lam_parts.append((edges[:, None] + 0.5 * (x[None, :] + 1.0)).ravel())
        quad_parts.append(np.tile(0.5 * w, edges.size))
    lam, quad = np.concatenate(lam_parts), np.concatenate(quad_parts)
    order = np.argsort(lam)
    return lam[order], quad[order]


def _demodulated_samples(weights: np.ndarray, nu: np.ndarray, step_nm: float, count: int) -> np.ndarray:
    """f, f', f'' (3 each, count) of f(x) = Σ_j weights_cj e^{i2πx(ν_j − ν0)} at x = k·step.

    Blocks of x share one phase table: e^{iθ(x_b + k h)} = e^{iθ x_b}·e^{iθ k h}
    (one rounding per factor, so no error builds up along the table).
    """
    dnu = 2j * np.pi * (nu - NU0_PER_NM)
    columns = np.concatenate([weights, weights * dnu, weights * dnu**2]).T  # (nodes, 9)
    steps = np.exp(np.outer(step_nm * np.arange(_X_BLOCK), dnu))
    out = np.empty((count, 9), complex)
    for s in range(0, count, _X_BLOCK):
        n = min(_X_BLOCK, count - s)
        out[s : s + n] = (steps[:n] * np.exp(s * step_nm * dnu)) @ columns
    return out.T.reshape(3, 3, count)


def _hermite_coefficients(f: np.ndarray, h: float) -> np.ndarray:
    """Monomial coefficients in t of the quintic Hermite pieces; f = (f, f', f'') × (3, N+1)."""
    v0, v1 = f[0][:, :-1], f[0][:, 1:]
    d0, d1 = h * f[1][:, :-1], h * f[1][:, 1:]
    s0, s1 = h * h * f[2][:, :-1], h * h * f[2][:, 1:]
    dv = v1 - v0
    c = [
        v0,
        d0,
        0.5 * s0,
        10 * dv - 6 * d0 - 4 * d1 - 1.5 * s0 + 0.5 * s1,
        -15 * dv + 8 * d0 + 7 * d1 + 1.5 * s0 - s1,
        6 * dv - 3 * d0 - 3 * d1 - 0.5 * s0 + 0.5 * s1,
    ]
    return np.stack(c, axis=-1).transpose(1, 0, 2)  # (N, 3, 6)


def _decay_constants(table_nm: np.ndarray, table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(edge, variation) of w̃(ν) = w(1/ν)/ν² for the piecewise-linear table (3, 471).

    Integrating Ŵ by parts twice: |Ŵ(x)| ≤ edge/(2πx) + variation/(2πx)², with
    edge = |w̃(ν_min)| + |w̃(ν_max)| and variation = |w̃'| at both ends plus the
    total variation of w̃' (its jumps at the table's kinks and ∫|w̃''| between).
    On a panel w = α + βλ, so w̃' = −2αν⁻³ − 3βν⁻⁴, whose only turning point
    is ν = −2β/α.
    """
    beta = np.diff(table, axis=1) / np.diff(table_nm)
    alpha = table[:, :-1] - beta * table_nm[:-1]
    nu_hi, nu_lo = 1.0 / table_nm[:-1], 1.0 / table_nm[1:]

    def slope(nu: np.ndarray) -> np.ndarray:
        return -2 * alpha * nu**-3 - 3 * beta * nu**-4

    with np.errstate(divide="ignore", invalid="ignore"):
        turn = np.where(alpha != 0, -2 * beta / alpha, np.nan)
    inside = (turn > nu_lo) & (turn < nu_hi)
    mid = np.where(inside, turn, nu_lo)
    within = np.abs(slope(mid) - slope(nu_lo)) + np.abs(slope(nu_hi) - slope(mid))
    jumps = np.abs(slope(nu_lo)[:, :-1] - slope(nu_hi)[:, 1:])  # panel k's left end meets panel k+1's right
    ends = np.abs(slope(nu_lo)[:, -1]) + np.abs(slope(nu_hi)[:, 0])
    edge = np.abs(table[:, 0]) * table_nm[0] ** 2 + np.abs(table[:, -1]) * table_nm[-1] ** 2
    return edge, ends + within.sum(axis=1) + jumps.sum(axis=1)


@functools.lru_cache(maxsize=8)
def weight_transform(
    observer: str = "cie1931",
    space: str = "rec709",
    basis: str = "rgb",
    step_nm: float = TABLE_STEP_NM,
    x_max_nm: float = TABLE_MAX_NM,
) -> WeightTransform:
    """Tabulate Ŵ_c on [0, x_max] at ``step_nm`` (cached per process)."""
    cm = colorimetry(observer, space)
    lam, quad = _panel_nodes(x_max_nm)
    weights = cm.sensitivity(lam, basis) * quad
    n = int(np.ceil(x_max_nm / step_nm))
    key = b"".join([weights.tobytes(), lam.tobytes(), np.float64(step_nm).tobytes(), np.int64(n).tobytes()])
    f = cached_arrays(
        "fourier", key, {"f": (3, 3, n + 1)}, lambda: {"f": _demodulated_samples(weights, 1.0 / lam, step_nm, n + 1)}
    )["f"]
    table = cm.rgb_table if basis == "rgb" else cm.xyz_table
    edge, variation = _decay_constants(cm.wavelength_nm, table)
    # f is band-limited to |ν − ν0| ≤ ν_half: |f⁽⁶⁾| ≤ (2πν_half)⁶ ∫|w|, and the
    # quintic Hermite remainder is f⁽⁶⁾/6! · t³(t−h)³ ≤ h⁶/46080 · |f⁽⁶⁾|.
    mass = np.abs(weights).sum(axis=1)
    half = 0.5 * (NU_MAX_PER_NM - NU_MIN_PER_NM)
    bound = step_nm**6 / 46080.0 * (2 * np.pi * half) ** 6 * mass
    return WeightTransform(float(step_nm), _hermite_coefficients(f, step_nm), mass, edge, variation, bound)


@dataclass
class SeriesCoefficients:
    """Per texel and polarization (leading axis s, p): the series' constants."""

    c0: np.ndarray  # (2, n) real
    k: np.ndarray  # (2, n) complex
    q: np.ndarray  # (2, n) complex
    one_minus_q: np.ndarray  # (2, n) 1 − |q| > 0 (without cancellation)
    x_nm: np.ndarray  # (n,) X = D·cos θ2
    in_scope: np.ndarray  # (n,) film propagating (cos θ2 > 0)


def series_coefficients(
    eta1: float | np.ndarray,
    eta2: float | np.ndarray,
    cos_theta: npt.ArrayLike,
    opd_nm: npt.ArrayLike,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
) -> SeriesCoefficients:
    """C0, K, q of every texel (flat arrays; η1, η2 scalars or flat arrays too), both polarizations.

    1 − |a|² = 4 Re(Y1 Ȳ2)/|Y1 + Y2|² and 1 − |b|² likewise, so
    1 − |q|² = (1 − |a|²) + |a|²(1 − |b|²) is a sum of terms ≥ 0 and keeps its
    relative accuracy as |q| → 1; 1 − a² = 4 Y1 Y2/(Y1 + Y2)² exactly. Where
    γ = 0 (grazing incidence: a = −1) the |γ|²/(1 − |q|²) term is 0, not 0/0.
    """
    cos_t = np.asarray(cos_theta, float)
    g2 = normal_admittance(eta2, 0.0, eta1, cos_t)
    in_scope = (g2.imag == 0) & (g2.real > 0)
    terms, _, _ = _stack_terms(eta1, eta2, eta3, kappa3, np.where(in_scope, cos_t, 1.0), 0.0, 500.0)
    out: dict[str, list[np.ndarray]] = {"c0": [], "k": [], "q": [], "one_minus_q": []}
    for pol in ("s", "p"):
        y1, y2, y3, _ = terms[pol]
        s12, s23 = y1 + y2, y2 + y3
        a, b = (y1 - y2) / s12, (y2 - y3) / s23
        abs_a2 = np.abs(a) ** 2
        one_a2 = 4 * np.real(y1 * np.conj(y2)) / np.abs(s12) ** 2
        one_b2 = np.maximum(4 * np.real(y2 * np.conj(y3)) / np.abs(s23) ** 2, 0.0)
        one_q2 = one_a2 + abs_a2 * one_b2
        gamma = b * (4 * y1 * y2 / s12**2)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(gamma == 0, 0.0, np.abs(gamma) ** 2 / one_q2)
        q = -a * b
        out["c0"].append(abs_a2 + ratio)
        out["k"].append(gamma * np.conj(a) + q * ratio)
        out["q"].append(q)
        out["one_minus_q"].append(one_q2 / (1 + np.abs(q)))
    x_nm = np.asarray(opd_nm, float) * np.where(in_scope, g2.real, 0.0) / eta2
    c0, k, q, one_minus_q = (np.array(out[key]) for key in ("c0", "k", "q", "one_minus_q"))
    return SeriesCoefficients(c0, k, q, one_minus_q, x_nm=x_nm, in_scope=in_scope)


def _remainder(co: SeriesCoefficients, wt: WeightTransform, terms: np.ndarray) -> np.ndarray:
    """Bound on Σ_pol |Σ_{m>M} K q^{m−1} Ŵ(mX)| after M = ``terms``: |K||q|^M/(1−|q|)·sup_{x≥(M+1)X}|Ŵ|."""
    with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
        geometric = np.abs(co.k) * np.abs(co.q) ** terms / co.one_minus_q
        geometric = np.where(co.k == 0, 0.0, geometric)
    return np.sum(geometric, axis=0) * wt.tail_bound((terms + 1) * co.x_nm)


def series_plan(
    co: SeriesCoefficients,
    wt: WeightTransform,
    tolerance: float = DEFAULT_SERIES_TOLERANCE,
    budget: int = SERIES_BUDGET,
) -> np.ndarray:
    """Terms M per texel for the series, or −1 for the direct quadrature.

    The rule: the texel is in scope (propagating film) and its remainder
    bound is ≤ ``tolerance`` within min(x_max/X, ``budget``) terms (inside
    the table; texels needing hundreds of terms are the high-finesse ones,
    whose direct rules are long too). M is then the smallest count whose
    remainder bound is ≤ tolerance (X = 0: closed form, M = 0; at grazing
    incidence K = 0, so M = 0 and R = C0 = 1). The bake kernel runs the same
    rule (series_cap and series_rgb in kernels/airy.cl).
    """
    n = co.x_nm.size
    with np.errstate(divide="ignore"):
        cap = np.where(co.x_nm > 0, np.floor(wt.x_max_nm / co.x_nm), 0.0)
    cap = np.minimum(cap, budget)
    ok = co.in_scope & (_remainder(co, wt, cap) <= tolerance)
    closed = co.in_scope & (co.x_nm == 0)
    lo, hi = np.zeros(n), np.where(ok & ~closed, cap, 0.0)
    while np.any(lo < hi):  # smallest M in [0, cap] meeting the bound (the bound falls with M)
        mid = np.floor(0.5 * (lo + hi))
        meets = _remainder(co, wt, mid) <= tolerance
        hi, lo = np.where(meets, mid, hi), np.where(meets, lo, mid + 1)
    return np.where(ok | closed, hi, -1).astype(np.int64)


PATHS = ("series", "closed-form", "direct")  # SeriesResult.path codes 0, 1, 2


@dataclass
class SeriesResult:
    """What ``series_colour`` gives per texel: its colour, terms, enforced bound and path."""

    values: np.ndarray | None  # (n, 3); NaN where the texel takes the direct path; None: not integrated
    terms: np.ndarray  # (n,) M where the series is summed, else −1
    bound: np.ndarray  # (n,) enforced a-priori |ΔRGB| bound (0 for direct texels)
    path: np.ndarray  # (n,) index into PATHS


def series_colour(
    stack: FilmPoints,
    observer: str = "cie1931",
    space: str = "rec709",
    basis: str = "rgb",
    tolerance: float = DEFAULT_SERIES_TOLERANCE,
    budget: int = SERIES_BUDGET,
    integrate: bool = True,
) -> SeriesResult:
    """RGB of film stacks of constant indices (points.FilmPoints, flat fields) in float64: by the series
    where its rule allows, else by the poles' closed form (lutbake/spectral/poles.py) where the film propagates
    and that form's bound is within ``tolerance`` per polarization, else left to the direct path (NaN).
    ``integrate=False``: the rule's outcome alone (``values`` None, no integration)."""
    stack.require("series", film=None, base=None)
    wt = weight_transform(observer, space, basis)
    co = series_coefficients(
        stack.eta1, stack.eta2, np.asarray(stack.cos_theta, float), stack.opd_nm, stack.eta3, stack.kappa3
    )
    terms = series_plan(co, wt, tolerance, budget)
    values, bound = _series_sum(co, wt, terms) if integrate else (None, np.where(terms >= 0, np.nan, 0.0))
    path = np.where(terms >= 0, 0, 2)
    todo = np.flatnonzero((terms < 0) & co.in_scope)
    if todo.size:
        from lutbake.spectral.poles import closed_form

        forms = [closed_form(co.k[p, todo], co.q[p, todo], co.x_nm[todo], observer, space, integrate) for p in (0, 1)]
        ok = forms[0].ok & forms[1].ok & (np.maximum(forms[0].bound, forms[1].bound) <= tolerance)
        done = todo[ok]
        bound[done], path[done] = (forms[0].bound + forms[1].bound)[ok], 1
        s_integral, p_integral = (f.integral for f in forms)  # None unless integrating
        if values is not None and s_integral is not None and p_integral is not None:
            w0 = wt(np.zeros(1))[:, 0].real
            integrals = (s_integral, p_integral)
            rgb = 0.5 * sum(co.c0[p, todo][:, None] * w0 + 2 * f.real for p, f in enumerate(integrals))
            values[done] = rgb[ok]
    if values is not None:
        values[path == 2] = np.nan
    return SeriesResult(values, terms, bound, path)


def _series_sum(co: SeriesCoefficients, wt: WeightTransform, terms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(values (n, 3), bound (n,)) of the series with ``terms`` terms per texel (0 where terms < 0)."""
    w0 = wt(np.zeros(1))[:, 0]
    # X = 0: Σ_m K q^{m−1} = K/(1 − q); K = 0 wherever |q| = 1 (γ = 0).
    with np.errstate(divide="ignore", invalid="ignore"):
        closed = np.where(co.k == 0, 0.0, co.k / (1 - co.q))
    zero = co.x_nm == 0
    acc = np.where(zero, closed, 0.0)[..., None] * w0  # (2, n, 3)
    power = np.ones_like(co.q)
    for m in range(1, int(terms.max(initial=0)) + 1):
        active = np.flatnonzero(terms >= m)
        acc[:, active] += (co.k[:, active] * power[:, active])[..., None] * wt(m * co.x_nm[active]).T
        power[:, active] *= co.q[:, active]
    per_pol = co.c0[..., None] * w0.real + 2 * acc.real
    values = 0.5 * per_pol.sum(axis=0)
    # the table's error, carried through the M terms taken: Σ_pol |K| (1 − |q|^M)/(1 − |q|) · δ
    with np.errstate(divide="ignore", invalid="ignore"):
        taken = np.abs(co.k) * (1 - np.abs(co.q) ** np.maximum(terms, 0)) / co.one_minus_q
    interp = np.sum(np.where(co.k == 0, 0.0, taken), axis=0) * wt.interpolation_bound.max()
    bound = np.where(terms >= 0, _remainder(co, wt, np.maximum(terms, 0)) * ~zero + interp, 0.0)
    return values, bound
