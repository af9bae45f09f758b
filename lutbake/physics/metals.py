"""glTF metals as conductors: a base colour (F0 per channel) turned into a complex index η + iκ.

glTF's metal BRDF has no index: its Fresnel term is Schlick's curve through the base colour,
F(θ) = F0 + (1 − F0)(1 − cos θ)^5 (glTF 2.0, Appendix B). A thin film over the metal needs the
base's η3 + iκ3, so each channel's F0 is mapped to a conductor by one of:

* ``fitted`` (lutbake's default): the conductor with exactly that normal-incidence reflectance,
  ((η − 1)² + κ²)/((η + 1)² + κ²) = F0, whose unpolarised Fresnel reflectance R(θ) is closest to
  Schlick's curve in the maximum over cos θ ∈ [0, 1]. One free parameter remains once F0 is fixed:
  η between (1 − √F0)/(1 + √F0) and (1 + √F0)/(1 − √F0), κ following from F0. Within 0.03 of glTF's
  curve for every F0 (``python docs/make_gltf.py``).
* ``threejs``: three.js's iridescence, which takes a real index η = (1 + √F0)/(1 − √F0) and κ = 0:
  the same F0, but up to 0.5 off glTF's curve near grazing incidence (F0 → 1).

A white metal (F0 → 1) has no finite index: F0 is clamped to ``F0_MAX[mapping]`` (η3 ≤ 10, lutbake's
index domain, for ``threejs``; η ≥ 0.016 for ``fitted``) and the caller reports it.

References: Gulbrandsen, O. (2014), Artist friendly metallic Fresnel, JCGT 3(4) (the same
two-parameter family of conductors); KHR_materials_iridescence, three.js r187 ``evalIridescence``.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from lutbake.physics.optics import fresnel_p, fresnel_s, normal_admittance
from lutbake.physics.points import MAX_INDEX

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["MAPPINGS", "F0_MAX", "gltf_metal_reflectance", "conductor_reflectance", "conductor", "reflectance_error"]

MAPPINGS = ("fitted", "threejs")
F0_MAX = {"fitted": 0.99, "threejs": ((MAX_INDEX - 1.0) / (MAX_INDEX + 1.0)) ** 2}
_COS_GRID = np.linspace(0.0, 1.0, 1025)
_ETA_STEPS = 256  # coarse search over the free parameter before golden-section refinement
_GOLDEN_ITERATIONS = 40


def gltf_metal_reflectance(f0: ArrayLike, cos_theta: ArrayLike) -> np.ndarray:
    """glTF's metal Fresnel term: Schlick's curve F0 + (1 − F0)(1 − cos θ)^5."""
    f0, c = np.asarray(f0, float), np.asarray(cos_theta, float)
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def conductor_reflectance(eta: ArrayLike, kappa: ArrayLike, cos_theta: ArrayLike) -> np.ndarray:
    """Unpolarised Fresnel reflectance of a bare base η + iκ under air (η1 = 1) at cos θ."""
    eta, kappa, c = np.broadcast_arrays(*(np.asarray(v, float) for v in (eta, kappa, cos_theta)))
    g1, g3 = normal_admittance(1.0, 0.0, 1.0, c), normal_admittance(eta, kappa, 1.0, c)
    n3 = eta + 1j * kappa
    with np.errstate(invalid="ignore"):  # 0/0 only for a base matching air at grazing incidence: R → 0
        r = 0.5 * (np.abs(fresnel_s(g1, g3)) ** 2 + np.abs(fresnel_p(g1, g3, 1.0, n3)) ** 2)
    return np.nan_to_num(r, nan=0.0)


def _kappa_for(f0: float, eta: np.ndarray | float) -> np.ndarray:
    """κ ≥ 0 giving normal-incidence reflectance ``f0`` at real part ``eta`` (0 where none is needed)."""
    return np.sqrt(np.maximum(f0 * (eta + 1.0) ** 2 - (eta - 1.0) ** 2, 0.0) / (1.0 - f0))


def _max_error(f0: float, eta: ArrayLike, cos_grid: np.ndarray = _COS_GRID) -> np.ndarray:
    """max over ``cos_grid`` of |R(θ) − Schlick(θ)| for the conductor (eta, κ(f0, eta)), per eta."""
    eta = np.atleast_1d(eta)
    r = conductor_reflectance(eta[:, None], _kappa_for(f0, eta)[:, None], cos_grid[None, :])
    return np.abs(r - gltf_metal_reflectance(f0, cos_grid)[None, :]).max(axis=1)


@functools.lru_cache(maxsize=4096)
def _fitted(f0: float) -> tuple[float, float]:
    """(η, κ) of the ``fitted`` mapping for one F0 in [0, F0_MAX['fitted']]: a log-spaced search over
    η between its two κ = 0 ends (every 4th cos θ node), refined by golden sections around the best
    step (every node). Cached: a scene's metals share few distinct F0."""
    if f0 <= 0.0:
        return 1.0, 0.0
    r = np.sqrt(f0)
    lo, hi = np.log((1.0 - r) / (1.0 + r)), np.log((1.0 + r) / (1.0 - r))
    grid = np.linspace(lo, hi, _ETA_STEPS)
    best = int(np.argmin(_max_error(f0, np.exp(grid), _COS_GRID[::4])))
    a, b = grid[max(best - 1, 0)], grid[min(best + 1, _ETA_STEPS - 1)]
    ratio = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(_GOLDEN_ITERATIONS):
        x1, x2 = b - ratio * (b - a), a + ratio * (b - a)
        e1, e2 = _max_error(f0, np.exp([x1, x2]))
        a, b = (a, x2) if e1 <= e2 else (x1, b)
    eta = float(np.exp(0.5 * (a + b)))
    return eta, float(_kappa_for(f0, eta))


def conductor(f0: ArrayLike, mapping: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(η, κ) arrays for base colours ``f0`` (linear, per channel) by ``mapping``, F0 clamped to
    ``F0_MAX[mapping]``; and a bool array: where F0 was clamped."""
    given = np.atleast_1d(np.asarray(f0, float))
    clamped = given > F0_MAX[mapping]
    f0_used = np.clip(given, 0.0, F0_MAX[mapping])
    if mapping == "threejs":
        r = np.sqrt(f0_used)
        return np.minimum((1.0 + r) / (1.0 - r), MAX_INDEX), np.zeros_like(f0_used), clamped  # F0_MAX: η = 10 ± 1 ulp
    pairs = np.array([_fitted(float(v)) for v in f0_used]).reshape(-1, 2)
    return pairs[:, 0], pairs[:, 1], clamped


@functools.lru_cache(maxsize=4096)
def reflectance_error(eta: float, kappa: float, f0: float) -> dict[str, float]:
    """The searched maximum of |R(θ) − Schlick(θ)| over cos θ ∈ [0, 1] (the 1025-node grid's worst
    node, refined by golden sections between its neighbours): {'max', 'cos_theta'}."""
    err = np.abs(conductor_reflectance(eta, kappa, _COS_GRID) - gltf_metal_reflectance(f0, _COS_GRID))
    i = int(np.argmax(err))
    a, b = _COS_GRID[max(i - 1, 0)], _COS_GRID[min(i + 1, _COS_GRID.size - 1)]
    ratio = (np.sqrt(5.0) - 1.0) / 2.0

    def at(c: float) -> float:
        return float(abs(conductor_reflectance(eta, kappa, c) - gltf_metal_reflectance(f0, c)))

    for _ in range(_GOLDEN_ITERATIONS):
        x1, x2 = b - ratio * (b - a), a + ratio * (b - a)
        a, b = (a, x2) if at(x1) >= at(x2) else (x1, b)
    c = 0.5 * (a + b)
    best = max((at(c), c), (float(err[i]), float(_COS_GRID[i])), (at(0.0), 0.0), (at(1.0), 1.0))
    return {"max": best[0], "cos_theta": float(best[1])}
