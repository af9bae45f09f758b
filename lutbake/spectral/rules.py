"""Spectral quadrature rules: where R(λ) is sampled and with what RGB weights.

Every integrator computes RGB_c = Σ_j W_cj · R(λ_j). Two families of rules:

* ``panel_rule``: Gauss–Legendre nodes on each 1 nm panel of the CMF table.
  The sensitivity is linear on a panel, so the rule is exact up to how well
  the nodes resolve R(λ) itself; doubling the nodes until the result stops
  moving is the ground truth's convergence test.
* ``wavenumber_rule``: N nodes uniform in wavenumber ν = 1/λ, where the film
  phase Φ = 2π·D·cos θ2·ν is linear, with *product-integration* weights: the
  exact integral of the sensitivity against the piecewise-polynomial
  interpolant of R through the nodes (local degree-7 Lagrange). At D = 0
  (R constant) it is exact for any N; its error falls as (phase step)⁸, and
  ``RuleLadder`` picks N per texel from the film's fringe bandwidth. These
  are the rules the bake kernels run. Given the kinks of a dispersive
  material's spectrum (knots), the rule is cut there into panels so that no
  interpolant straddles one (scene slices of named materials).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from lutbake.io.usercache import cached_arrays
from lutbake.physics.colorimetry import WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, colorimetry

__all__ = [
    "SpectralRule",
    "RuleLadder",
    "panel_rule",
    "wavenumber_rule",
    "rule_ladder",
    "WAVENUMBER_SPAN_PER_NM",
    "DEFAULT_SAMPLES_PER_CYCLE",
    "MAX_WAVENUMBER_NODES",
]

WAVENUMBER_SPAN_PER_NM = 1.0 / WAVELENGTH_MIN_NM - 1.0 / WAVELENGTH_MAX_NM
DEFAULT_SAMPLES_PER_CYCLE = 3.0
_HARMONIC_TOLERANCE = 1e-6
STENCIL_NODES = 8
_MIN_WAVENUMBER_NODES = 16
MAX_WAVENUMBER_NODES = 16384
_PROJECTION_NODES = 8
MIN_PANEL_NODES = 4  # a knotted rule's narrowest panel: cubic interpolation there
_GAUSS_LEGENDRE = np.polynomial.legendre.leggauss(_PROJECTION_NODES)


@dataclass(frozen=True)
class SpectralRule:
    """Nodes λ_j (nm) and weights W (3, N) such that RGB ≈ W @ R(λ)."""

    wavelength_nm: np.ndarray
    weights: np.ndarray
    name: str

    @property
    def count(self) -> int:
        return self.wavelength_nm.size


@functools.lru_cache(maxsize=16)
def _gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """numpy's Gauss–Legendre nodes and weights on [−1, 1], read-only: an eigenvalue problem of the node count's
    size (0.08 s at 2,048), which a report's truth asked for dozens of times (4.9 of its 43 s)."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    x.flags.writeable = w.flags.writeable = False
    return x, w


@functools.lru_cache(maxsize=64)
def panel_rule(nodes_per_nm: int, observer: str = "cie1931", space: str = "rec709", basis: str = "rgb") -> SpectralRule:
    """Composite Gauss–Legendre rule, ``nodes_per_nm`` nodes on each 1 nm panel."""
    x, w = _gauss_legendre(int(nodes_per_nm))
    left = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)
    lam = (left[:, None] + 0.5 * (x[None, :] + 1.0)).ravel()
    quad = np.tile(0.5 * w, left.size)
    weights = colorimetry(observer, space).sensitivity(lam, basis) * quad
    return SpectralRule(lam, weights, f"gauss-legendre-{nodes_per_nm}/nm")


@functools.lru_cache(maxsize=64)
def wavenumber_rule(
    count: int,
    observer: str = "cie1931",
    space: str = "rec709",
    basis: str = "rgb",
    knots_nm: tuple[float, ...] = (),
) -> SpectralRule:
    """Uniform-wavenumber nodes with product-integration weights of local degree-7 interpolation.

    ``knots_nm``: wavelengths where R(λ) has a kink (a material table's samples: linear between
    them). Where ``count`` affords it (MIN_PANEL_NODES per piece), the span is cut at the knots
    into panels, each with its own uniform nodes no farther apart than ``count`` nodes over the
    whole span, so no interpolating polynomial straddles a kink: the rule then converges as fast
    as for a smooth spectrum, where a kink inside a stencil costs O(h²)."""
    if count < STENCIL_NODES:
        raise ValueError(f"wavenumber rule count {count} is below the {STENCIL_NODES} a stencil needs")
    cuts = sorted(k for k in knots_nm if WAVELENGTH_MIN_NM < k < WAVELENGTH_MAX_NM)
    if (len(cuts) + 1) * MIN_PANEL_NODES > count:
        cuts = []
    edges_nm = [WAVELENGTH_MIN_NM, *cuts, WAVELENGTH_MAX_NM]
    step = WAVENUMBER_SPAN_PER_NM / (count - 1)
    panels = [
        (lo, hi, max(MIN_PANEL_NODES, int(np.ceil((1.0 / lo - 1.0 / hi) / step)) + 1) if cuts else count)
        for lo, hi in zip(edges_nm[:-1], edges_nm[1:])
    ]
    size = sum(n for _, _, n in panels)
    cm = colorimetry(observer, space)
    # Built once per machine (up to ~0.1 s per rule): keyed by the sensitivity table, the panels and
    # this module's construction code, so a changed table or construction never reads a stale entry.
    key = b"|".join(
        [
            _construction_digest(),
            (cm.rgb_table if basis == "rgb" else cm.xyz_table).tobytes(),
            np.asarray(panels, float).tobytes(),
        ]
    )
    rows = 3 * len(basis.split("+"))
    rule = cached_arrays(
        "wavenumber-rule",
        key,
        {"wavelength_nm": (size,), "weights": (rows, size)},
        lambda: _panel_rule_arrays(panels, observer, space, basis),
    )
    name = f"wavenumber-lagrange{STENCIL_NODES}-{count}" + (f"-{len(panels)}-panels" if cuts else "")
    return SpectralRule(rule["wavelength_nm"], rule["weights"], name)


@functools.lru_cache(maxsize=1)
def _construction_digest() -> bytes:
    source = "".join(
        inspect.getsource(f) for f in (_panel_rule_arrays, _product_weights, _projection_points, _lagrange_stencils)
    )
    constants = (STENCIL_NODES, _PROJECTION_NODES, MIN_PANEL_NODES)
    return hashlib.sha256(f"{source}{constants}".encode()).digest()


def _panel_rule_arrays(
    panels: list[tuple[float, float, int]], observer: str, space: str, basis: str
) -> dict[str, np.ndarray]:
    """Nodes and weights of a rule over ``panels`` ((lo_nm, hi_nm, nodes) each), panel by panel."""
    nodes, weights = [], []
    for lo, hi, n in panels:
        nu = np.linspace(1.0 / hi, 1.0 / lo, n)
        nodes.append(nu)
        weights.append(_product_weights(nu, lo, hi, observer, space, basis))
    return {"wavelength_nm": 1.0 / np.concatenate(nodes), "weights": np.concatenate(weights, axis=1)}


def _product_weights(nu: np.ndarray, lo_nm: float, hi_nm: float, observer: str, space: str, basis: str) -> np.ndarray:
    """(rows, nodes) weights: the sensitivity integrated over [lo_nm, hi_nm] exactly against the
    local Lagrange basis through the uniform nodes ``nu`` (ascending, spanning that range)."""
    lam, quad = _projection_points(1.0 / nu, lo_nm, hi_nm)
    sens = colorimetry(observer, space).sensitivity(lam, basis) * quad
    order = min(STENCIL_NODES, nu.size)
    start, basis_values = _lagrange_stencils(nu, 1.0 / lam, order)
    weights = np.zeros((sens.shape[0], nu.size))
    for k in range(order):
        for c in range(sens.shape[0]):
            weights[c] += np.bincount(start + k, sens[c] * basis_values[k], minlength=nu.size)
    return weights


def _projection_points(node_wavelength_nm: np.ndarray, lo_nm: float, hi_nm: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre points and weights on every piece of [lo_nm, hi_nm] between consecutive
    breakpoints (the 1 nm CMF samples and the rule's nodes): the integrand — a linear
    sensitivity times a polynomial in ν — is smooth on each piece, so the projection is exact
    to rounding for any node count."""
    samples = np.arange(WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM + 0.5)
    edges = np.union1d(samples[(samples >= lo_nm) & (samples <= hi_nm)], np.clip(node_wavelength_nm, lo_nm, hi_nm))
    x, w = _GAUSS_LEGENDRE
    left, width = edges[:-1], np.diff(edges)
    lam = (left[:, None] + 0.5 * width[:, None] * (x[None, :] + 1.0)).ravel()
    return lam, (0.5 * width[:, None] * w[None, :]).ravel()


@dataclass(frozen=True)
class RuleLadder:
    """Wavenumber rules of 16·2^k nodes, k = 0 … levels − 1, for per-texel choice.

    With constant indices a texel's R depends on ν only through the phase
    Φ = 2π·D·cos θ2·ν, so R(ν) is periodic with ``cycles`` = D·cos θ2·Δν
    periods over the visible span. Its Fourier series in Φ decays as
    |r21·r23|^m, so m ≈ ln(1/ε)/(−ln |r21·r23|) harmonics (ε = 1e-6) carry it:
    high finesse (|r21 r23| → 1, metals at grazing incidence) sharpens the
    Airy peaks. A texel's bandwidth is cycles × harmonics; the rule needs
    ``samples_per_cycle`` nodes per bandwidth cycle (3 measured to give
    |ΔRGB| ≤ 1.2e-6, 2 to give 1.2e-5; bench/bench_spectral_rule.py). ``level`` picks the
    smallest rule with that many nodes, capped at MAX_WAVENUMBER_NODES: the
    enforced truncation bound, whose residual the bake measures and records.
    """

    samples_per_cycle: float
    observer: str = "cie1931"
    space: str = "rec709"
    knots_nm: tuple[float, ...] = ()  # kinks of the materials' spectra (wavenumber_rule), none for constant indices

    @property
    def counts(self) -> list[int]:
        n, out = _MIN_WAVENUMBER_NODES, []
        while n <= MAX_WAVENUMBER_NODES:
            out.append(n)
            n *= 2
        return out

    def rule(self, level: int) -> SpectralRule:
        return wavenumber_rule(self.counts[level], self.observer, self.space, knots_nm=self.knots_nm)

    def _needed(self, cycles: npt.ArrayLike, round_trip: npt.ArrayLike) -> np.ndarray:
        b = np.clip(np.asarray(round_trip, float), 1e-300, 1.0)
        with np.errstate(divide="ignore"):
            harmonics = np.maximum(1.0, np.log(1.0 / _HARMONIC_TOLERANCE) / -np.log(b))
        return self.samples_per_cycle * np.asarray(cycles, float) * harmonics + 1.0

    def level(self, cycles: npt.ArrayLike, round_trip: npt.ArrayLike) -> np.ndarray:
        """Rule level per texel from its fringe cycles and |r21·r23| (arrays)."""
        needed = self._needed(cycles, round_trip)
        level = np.ceil(np.log2(np.maximum(needed, 1.0) / _MIN_WAVENUMBER_NODES))
        return np.clip(level, 0, len(self.counts) - 1).astype(np.int32)

    def truncation_estimate(self, cycles: npt.ArrayLike, round_trip: npt.ArrayLike) -> np.ndarray:
        """Bound on the |ΔRGB| a texel keeps past the cap (0 below it).

        The cap resolves m = (N_max − 1)/(samples_per_cycle · cycles) harmonics
        of a series whose terms decay as |r21 r23|^m; the bound takes the tail
        at 10·|r21 r23|^m. It is loose where R ≈ 1 (measured residuals are
        orders of magnitude smaller; docs/stability.md), so bakes also measure.
        """
        needed = self._needed(cycles, round_trip)
        resolved = (MAX_WAVENUMBER_NODES - 1.0) / (self.samples_per_cycle * np.maximum(cycles, 1e-300))
        bound = 10.0 * np.clip(np.asarray(round_trip, float), 0.0, 1.0) ** resolved
        return np.where(needed > MAX_WAVENUMBER_NODES, np.clip(bound, _HARMONIC_TOLERANCE, 1.0), 0.0)


def rule_ladder(
    samples_per_cycle: float = DEFAULT_SAMPLES_PER_CYCLE,
    observer: str = "cie1931",
    space: str = "rec709",
    knots_nm: Iterable[float] = (),
) -> RuleLadder:
    """The ladder of wavenumber rules for ``samples_per_cycle`` nodes per fringe cycle (``RuleLadder``)."""
    return RuleLadder(float(samples_per_cycle), observer, space, tuple(knots_nm))


def _lagrange_stencils(nodes: np.ndarray, x: np.ndarray, order: int = STENCIL_NODES) -> tuple[np.ndarray, np.ndarray]:
    """First node of each point's ``order``-node stencil (centred where possible)
    and the Lagrange basis values there, shape (order, len(x))."""
    h = nodes[1] - nodes[0]
    s = (x - nodes[0]) / h
    start = np.clip(np.floor(s).astype(int) - (order // 2 - 1), 0, nodes.size - order)
    t = s - start
    values = np.empty((order, x.size))
    for k in range(order):
        others = [m for m in range(order) if m != k]
        values[k] = np.prod([(t - m) / (k - m) for m in others], axis=0)
    return start, values
