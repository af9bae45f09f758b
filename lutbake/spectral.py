"""Spectral quadrature rules: where R(λ) is sampled and with what RGB weights.

Every integrator computes RGB_c = Σ_j W_cj · R(λ_j). Two families of rules:

* ``panel_rule``: Gauss–Legendre nodes on each 1 nm panel of the CMF table.
  The sensitivity is linear on a panel, so the rule is exact up to how well
  the nodes resolve R(λ) itself; doubling the nodes until the result stops
  moving is the ground truth's convergence test.
* ``wavenumber_rule``: N nodes uniform in wavenumber ν = 1/λ, where the film
  phase Φ = 2π·D·cos θ2·ν is linear, with *product-integration* weights: the
  exact integral of the sensitivity against the piecewise-cubic Lagrange
  interpolant of R through the nodes. At D = 0 (R constant) it is exact for
  any N; its error grows as (phase step per node)⁴, so N follows the
  largest optical path difference (``wavenumber_count``). This is the rule
  the bake kernels run.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .colorimetry import WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, colorimetry

__all__ = ["SpectralRule", "panel_rule", "wavenumber_rule", "wavenumber_count",
           "WAVENUMBER_SPAN_PER_NM", "DEFAULT_SAMPLES_PER_CYCLE"]

WAVENUMBER_SPAN_PER_NM = 1.0 / WAVELENGTH_MIN_NM - 1.0 / WAVELENGTH_MAX_NM
DEFAULT_SAMPLES_PER_CYCLE = 6.0
_MIN_WAVENUMBER_NODES = 16
_PROJECTION_NODES_PER_NM = 8


@dataclass(frozen=True)
class SpectralRule:
    """Nodes λ_j (nm) and weights W (3, N) such that RGB ≈ W @ R(λ)."""

    wavelength_nm: np.ndarray
    weights: np.ndarray
    name: str

    @property
    def count(self) -> int:
        return self.wavelength_nm.size

    @property
    def wavenumber_per_nm(self) -> np.ndarray:
        return 1.0 / self.wavelength_nm


@functools.lru_cache(maxsize=64)
def panel_rule(nodes_per_nm: int, observer: str = "cie1931", space: str = "rec709",
               basis: str = "rgb") -> SpectralRule:
    """Composite Gauss–Legendre rule, ``nodes_per_nm`` nodes on each 1 nm panel."""
    x, w = np.polynomial.legendre.leggauss(int(nodes_per_nm))
    left = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)
    lam = (left[:, None] + 0.5 * (x[None, :] + 1.0)).ravel()
    quad = np.tile(0.5 * w, left.size)
    weights = colorimetry(observer, space).sensitivity(lam, basis) * quad
    return SpectralRule(lam, weights, f"gauss-legendre-{nodes_per_nm}/nm")


def wavenumber_count(opd_max_nm: float, samples_per_cycle: float = DEFAULT_SAMPLES_PER_CYCLE) -> int:
    """Nodes for ``wavenumber_rule`` so a fringe of OPD ``opd_max_nm`` gets the given samples.

    R(ν) repeats every 1/D in ν, so over the visible span it runs through
    D·Δν cycles (|cos θ2| ≤ 1 only shortens them).
    """
    cycles = float(opd_max_nm) * WAVENUMBER_SPAN_PER_NM
    return max(_MIN_WAVENUMBER_NODES, int(np.ceil(samples_per_cycle * cycles)) + 1)


@functools.lru_cache(maxsize=64)
def wavenumber_rule(count: int, observer: str = "cie1931", space: str = "rec709",
                    basis: str = "rgb") -> SpectralRule:
    """Uniform-wavenumber nodes with cubic product-integration weights."""
    if count < 4:
        raise ValueError(f"wavenumber rule count {count} is below the 4 a cubic needs")
    nu = np.linspace(1.0 / WAVELENGTH_MAX_NM, 1.0 / WAVELENGTH_MIN_NM, count)
    fine = panel_rule(_PROJECTION_NODES_PER_NM, observer, space, basis)
    start, basis_values = _cubic_stencils(nu, 1.0 / fine.wavelength_nm)
    weights = np.zeros((3, count))
    for k in range(4):
        for c in range(3):
            weights[c] += np.bincount(start + k, fine.weights[c] * basis_values[k], minlength=count)
    return SpectralRule(1.0 / nu, weights, f"wavenumber-cubic-{count}")


def _cubic_stencils(nodes, x):
    """First node of each point's 4-node stencil and the 4 Lagrange basis values."""
    h = nodes[1] - nodes[0]
    s = (x - nodes[0]) / h
    start = np.clip(np.floor(s).astype(int) - 1, 0, nodes.size - 4)
    t = s - start
    values = np.empty((4, x.size))
    for k in range(4):
        others = [m for m in range(4) if m != k]
        values[k] = np.prod([(t - m) / (k - m) for m in others], axis=0)
    return start, values
