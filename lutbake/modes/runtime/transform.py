"""The film- and base-independent function the runtime table holds, in float64.

Per polarization and colour channel c the film's colour is (docs/spectral.md)

    C0 Ŵ_c(0) + 2 Re[K S_c],   S_c = Σ_{m≥1} q^{m−1} Ŵ_c(mX),   X = D cos θ2 (nm).

With the demodulated transform A_c(x) = Ŵ_c(x) e^{−i2πν0x} (fourier.weight_transform) and
z = q e^{i2πν0X}, S_c = e^{i2πν0X} T_c(X, z), T_c(X, z) = Σ_{m≥1} z^{m−1} A_c(mX): a function of
X ≥ 0 and z in the closed unit disc only, the same for every film and base. The table stores

    U_c(X, w) = (1 − z) T_c(X, z),   z = (w + α)/(1 + α w),   α = 1 − β,   β = 2X/(2X + L)

U is bounded where T has its resonance (T ~ A(0)/(1 − z) as z → 1 for small X), and the Möbius zoom w
spreads the resonance of thin films, |1 − z| ~ X·bandwidth, over the table: as X → 0 at fixed w,
U → U0(s) with s = (1 − z)/X → (2/L)(1 − w)/(1 + w) (the limit slice). ``L`` = ZOOM_NM.

How U is computed:
- X > 0: summation by parts, U = A(X) + Σ_{m≥1} z^m [A((m+1)X) − A(mX)], whose differences decay as
  1/m² even on |z| = 1; the sum stops where mX passes the transform's table (4e5 nm).
- X → 0⁺ (slice 0): U0 = ∫ w(λ) s/(s − i2π(1/λ − ν0)) dλ, exactly (w is linear on each 1 nm panel:
  each panel integrates in closed form with one complex logarithm at each end).
- Nodes of the square grid outside the disc (|w| > 1) hold the value on the rim below them, so bilinear
  reads near the rim see no step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.io.usercache import cached_arrays
from lutbake.physics.colorimetry import colorimetry
from lutbake.spectral.fourier import NU0_PER_NM, TABLE_MAX_NM, weight_transform

if TYPE_CHECKING:
    from lutbake.spectral.fourier import WeightTransform

__all__ = [
    "X_MAX_NM",
    "ZOOM_NM",
    "SLICES",
    "NODES",
    "slice_positions",
    "node_grid",
    "zoom_beta",
    "z_of_w",
    "transform_values",
    "slice_values",
    "transform_table",
]

X_MAX_NM = 9000.0  # X = 2 η2 d cos θ2: η2 ≤ 3 and d ≤ 1500 nm at normal incidence
ZOOM_NM = 250.0  # s = 2/L at w = 0: the resonance of thin films (|s| ~ 2π × 7.85e-4 nm⁻¹) near the middle
SLICES = 129  # X nodes, uniform in √X (slice 0: the X → 0⁺ limit)
NODES = 33  # w nodes per axis on [−1, 1]; odd, so w = −1 (where every X = 0 lands) is a node
_BLOCK = 256  # terms per matrix product in the series


def slice_positions() -> np.ndarray:
    """X (nm) of each slice: uniform in √X from 0 to X_MAX_NM."""
    return X_MAX_NM * np.linspace(0.0, 1.0, SLICES) ** 2


def node_grid() -> np.ndarray:
    """w at every node, (NODES, NODES) complex, indexed [Im row, Re column]."""
    axis = np.linspace(-1.0, 1.0, NODES)
    return axis[None, :] + 1j * axis[:, None]


def zoom_beta(x_nm: npt.ArrayLike) -> np.ndarray:
    """β = 1 − α of the zoom at X: 2X/(2X + L) (0 at X = 0, → 1 for X ≫ L)."""
    x = np.asarray(x_nm, float)
    return 2.0 * x / (2.0 * x + ZOOM_NM)


def z_of_w(w: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """z for table coordinate w at zoom β (the inverse Möbius map; 1 − z = β(1 − w)/(1 + (1 − β)w))."""
    return 1.0 - beta * (1.0 - w) / (1.0 + (1.0 - beta) * w)


def _demodulated(wt: WeightTransform, x: np.ndarray) -> np.ndarray:
    """A_c(x) = Ŵ_c(x) e^{−i2πν0x}, (3, n)."""
    return wt(x) * np.exp(-2j * np.pi * NU0_PER_NM * x)[None]


def _series(wt: WeightTransform, x_nm: float, z: np.ndarray) -> np.ndarray:
    """U(X, z) for X > 0 at |z| ≤ 1: A(X) + Σ_m z^m ΔA_m, blocks of terms as matrix products, (3, n).

    A node leaves the sum once |z|^m Σ_{m' ≥ m}|ΔA_m'| ≤ 1e-12 (nodes sorted by |z|, so the ones still
    summing are a prefix): only nodes near the rim take every term up to the table's end."""
    terms = int(TABLE_MAX_NM // x_nm)
    a = _demodulated(wt, x_nm * np.arange(1, terms + 1))
    delta = np.diff(a, axis=1)  # ΔA_m, m = 1 … terms − 1
    remaining = np.cumsum(np.abs(delta).max(axis=0)[::-1])[::-1]
    order = np.argsort(-np.abs(z))
    zs = z[order]
    powers = np.cumprod(np.vstack([np.ones_like(zs), np.broadcast_to(zs, (_BLOCK - 1, zs.size))]), axis=0)
    step = powers[-1] * zs  # z^_BLOCK
    lead = zs.copy()  # z^(first m of the block)
    acc = np.zeros((3, zs.size), complex)
    active = zs.size
    for start in range(0, delta.shape[1], _BLOCK):
        active = int(np.count_nonzero(np.abs(lead[:active]) * remaining[start] > 1e-12))
        if active == 0:
            break
        block = delta[:, start : start + _BLOCK]
        acc[:, :active] += (block @ powers[: block.shape[1], :active]) * lead[None, :active]
        lead[:active] *= step[:active]
    out = np.empty_like(acc)
    out[:, order] = acc
    return a[:, :1] + out


def _limit(observer: str, space: str, w: np.ndarray) -> np.ndarray:
    """U0(w) = lim_{X→0⁺} U, (3, n): ∫ w(λ)·sλ/(pλ − c) dλ, p = s + i2πν0, c = i2π, per 1 nm panel."""
    cm = colorimetry(observer, space)
    lam, table = cm.wavelength_nm.astype(float), cm.rgb_table
    far = np.abs(1.0 + w) < 1e-12  # w = −1: s = ∞, U0 = ∫w
    s = (2.0 / ZOOM_NM) * (1.0 - w) / np.where(far, 1.0, 1.0 + w)
    s = np.where(s.real < 1e-15, 1e-15 + 1j * s.imag, s)  # the rim (Re s = 0) from inside the disc
    p, c = s + 2j * np.pi * NU0_PER_NM, 2j * np.pi
    slope = np.diff(table, axis=1) / np.diff(lam)  # w = α + βλ on each panel
    intercept = table[:, :-1] - slope * lam[:-1]
    logs = np.diff(np.log(p[:, None] * lam[None, :] - c), axis=1)  # principal log: pλ − c stays in Re ≥ 0
    # ∫ (α + βλ)·c/(pλ − c) dλ = c[β Δλ/p + (α + βc/p) Δlog/p]
    pp = p[:, None, None]
    panels = c * (slope[None] * np.diff(lam) / pp + (intercept[None] + slope[None] * c / pp) * logs[:, None] / pp)
    mass = np.trapezoid(table, lam, axis=1)
    value = (s / p)[:, None] * (mass[None] + panels.sum(axis=2))
    return np.where(far[:, None], mass[None], value).T


def transform_values(x_nm: float, w: np.ndarray, observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """U_c(X, w) at points of the closed unit disc (flat complex w), (3, n)."""
    if x_nm == 0.0:
        return _limit(observer, space, w)
    return _series(weight_transform(observer, space), x_nm, z_of_w(w, zoom_beta(x_nm)))


def slice_values(x_nm: float, observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """U_c(X, ·) at every node of the grid, (3, NODES, NODES); a node outside the disc holds the value on the
    rim below it, w/|w| (reads near the rim then see no step; a smooth reflection, 2U(w/|w|) − U(1/w̄),
    measured no better)."""
    w = node_grid().ravel()
    return transform_values(x_nm, w / np.maximum(np.abs(w), 1.0), observer, space).reshape(3, NODES, NODES)


def transform_table(observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """U_c at every slice and node, (3, SLICES, NODES, NODES) complex: built once per machine (~10 s of
    CPU, the smallest slices' long sums) and kept in the user cache (lutbake/io/usercache.py)."""
    cm = colorimetry(observer, space)
    key = b"".join(
        [
            cm.rgb_table.tobytes(),
            np.array([X_MAX_NM, ZOOM_NM, SLICES, NODES, TABLE_MAX_NM, NU0_PER_NM]).tobytes(),
            b"runtime-transform-v2",
        ]
    )
    shape = (3, SLICES, NODES, NODES)

    def build() -> dict[str, np.ndarray]:
        u = np.stack([slice_values(x, observer, space) for x in slice_positions()], axis=1)
        return {"re": u.real, "im": u.imag}

    arrays = cached_arrays("runtime", key, {"re": shape, "im": shape}, build)
    return arrays["re"] + 1j * arrays["im"]
