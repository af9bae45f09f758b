"""Integrate a scene slice: RGB on a (cos θ, film thickness) grid over one fixed base.

A slice goes through the bake's integrator (lutbake/integrate/opencl.py), by one of two
paths, chosen by the slice's materials:

* constant film η2 and constant base η3 + iκ3: the 4D kernel path itself.
  The slice is the (η3, κ3) tile of a spec whose base axes have two nodes,
  one of them exactly the slice's base, so every texel is summed by the
  Fourier series or the direct quadrature per texel, exactly as a 4D LUT's;
  only the image rows of that κ3 node are baked.
* a named (dispersive) film or base: the series assumes indices constant in
  λ, so every texel takes the direct quadrature, at the node count the
  spectral rule ladder gives its fringes (cycles at the film's largest
  index, |r21·r23| at its largest over the visible), with the indices taken
  at each node, summed on the device (integrate.stack_colour: the Fresnel
  side once per distinct cos θ × node; numpy only where no OpenCL device
  exists). The materials' tables are linear between samples: their kinks
  converge a uniform rule as O(h²) (silver needed 512 nodes for 2.5e-6,
  copper 1024), so the stack's rules are cut at the kinks
  (spectral.wavenumber_rule's knots; materials.knots_nm) and converge as for
  a smooth spectrum. A slice also takes at least the floor at which probe
  texels, each at its own level, agree with the next finer rule to
  DISPERSIVE_TOLERANCE / 4 (_material_level).

The held-out truth a slice is scored against stays lutbake/spectral/reference.py's
converged integration, which shares none of this code.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeAlias

import numpy as np
from numpy.typing import ArrayLike

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.physics.materials import material
from lutbake.physics.optics import normal_admittance, round_trip_amplitude
from lutbake.physics.points import MAX_INDEX, MAX_OPD_NM, FilmPoints
from lutbake.spectral.reference import spectral_reflectance, subset
from lutbake.spectral.rules import WAVENUMBER_SPAN_PER_NM, RuleLadder, SpectralRule, rule_ladder

if TYPE_CHECKING:
    from lutbake.integrate.numpy_path import NumpyBackend
    from lutbake.integrate.opencl import OpenCLBackend

    # What integrate.opencl.backend returns: the OpenCL kernels, or numpy where no device runs them.
    Integrator: TypeAlias = OpenCLBackend | NumpyBackend

__all__ = ["SliceStack", "slice_grid", "integrate_slice", "slice_colour"]

# Wavelengths at which a dispersive stack's fringe count and finesse are screened for its rule level.
_SCREEN_NM = np.linspace(360.0, 830.0, 48)
# |ΔRGB| a dispersive slice's rule is converged to: ~100× below the smallest colour step the scene targets
# resolve (ΔE00 0.5 is ~3e-3 in RGB), and what tests hold it to against the ground truth.
DISPERSIVE_TOLERANCE = 1e-5
_PROBE_COS = np.array([0.01, 0.25, 0.5, 0.75, 1.0])


class SliceStack:
    """The fixed part of a slice's film stack: ambient η1, film (η2 or a name), base ((η3, κ3) or a name)."""

    def __init__(self, eta1: float, film: float | str, base: tuple[float, float] | str):
        self.eta1, self.film, self.base = float(eta1), film, base
        # (thickness range, observer, space) -> _material_level, found once
        self.material_levels: dict[tuple[tuple[float, ...], str, str], int] = {}

    @property
    def dispersive(self) -> bool:
        return isinstance(self.film, str) or isinstance(self.base, str)

    def ladder(self, observer: str, space: str) -> RuleLadder:
        """The rule ladder of this stack: its rules cut at the kinks of its materials' spectra."""
        named = [material(m) for m in (self.film, self.base) if isinstance(m, str)]
        knots = tuple(sorted(set().union(*(m.knots_nm for m in named))))
        return rule_ladder(observer=observer, space=space, knots_nm=knots)

    def points(self, cos_theta: ArrayLike, thickness_nm: ArrayLike) -> FilmPoints:
        film = {"film": self.film} if isinstance(self.film, str) else {"eta2": self.film}
        base = {"base": self.base} if isinstance(self.base, str) else {"eta3": self.base[0], "kappa3": self.base[1]}
        return FilmPoints.build(eta1=self.eta1, cos_theta=cos_theta, thickness_nm=thickness_nm, **film, **base)


def slice_grid(
    counts: tuple[int, ...], thickness_nm: tuple[float, float], centres: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """(cos θ values, thickness values in nm) of a slice with ``counts`` = (n_cos, n_thickness): its nodes,
    uniform in √cos θ over [0, 1] and in thickness over ``thickness_nm`` (one row at the lower end when
    n_thickness is 1), or with ``centres`` the centres of its cells in those coordinates (where bilinear
    interpolation errs most: the points `report` scores beside uniform ones)."""
    lo, hi = thickness_nm
    n_cos, n_d = counts
    if centres:
        u, v = (np.arange(n_cos - 1) + 0.5) / (n_cos - 1), (np.arange(n_d - 1) + 0.5) / max(n_d - 1, 1)
    else:
        u, v = np.linspace(0.0, 1.0, n_cos), np.linspace(0.0, 1.0, n_d)
    return u**2, (lo + (hi - lo) * v) if n_d > 1 else np.array([float(lo)])


def integrate_slice(
    stack: SliceStack,
    counts: tuple[int, ...],
    thickness_nm: tuple[float, float],
    integrator: Integrator,
    observer: str,
    space: str,
    centres: bool = False,
) -> np.ndarray:
    """RGB (n_thickness, n_cos, 3) in float64 on the slice grid, or with ``centres`` at its cells'
    centres (max(n_thickness − 1, 1), n_cos − 1, 3) (``slice_grid``; the module docstring gives the path)."""
    cos_t, thickness = slice_grid(counts, thickness_nm, centres)
    if not stack.dispersive:
        return _kernel_tile(stack, cos_t, thickness, integrator, observer, space)
    grid_cos, grid_d = (g.ravel() for g in np.meshgrid(cos_t, thickness))
    rgb = slice_colour(stack, stack.points(grid_cos, grid_d), thickness_nm, integrator, observer, space)
    return rgb.reshape(thickness.size, cos_t.size, 3)


def slice_colour(
    stack: SliceStack,
    points: FilmPoints,
    thickness_nm: tuple[float, float],
    integrator: Integrator,
    observer: str,
    space: str,
) -> np.ndarray:
    """RGB (P, 3) of ``stack`` at any ``points`` of its slice (thickness within ``thickness_nm``) by the
    direct quadrature, each point at its fringe level and at least the slice's material floor: what a
    slice's interpolation error is scored against (≤ DISPERSIVE_TOLERANCE from the ground truth, tests)."""
    key = (tuple(thickness_nm), observer, space)
    if key not in stack.material_levels:
        stack.material_levels[key] = (
            _material_level(stack, thickness_nm, integrator, stack.ladder(observer, space)) if stack.dispersive else 0
        )
    return _direct_per_wavelength(stack, points, stack.material_levels[key], integrator, observer, space)


def _pinned_axis(name: str, value: float, top: float, partner: float | None = None) -> tuple[Axis, int]:
    """(two-node Axis with ``value`` exactly at one node, that node's index). The other node is
    ``partner`` when given and distinct, else ``value`` nudged up (down at the domain's top)."""
    if partner is not None and partner != value:
        lo, hi = sorted((value, partner))
        return Axis(name, lo, hi, 2), int(value == hi)
    step = 1e-6 * max(1.0, abs(value))
    if value + step <= top:
        return Axis(name, value, value + step, 2), 0
    return Axis(name, value - step, value, 2), 1


def _grid_axis(name: str, values: np.ndarray, top: float, spacing: str = "uniform") -> tuple[Axis, slice]:
    """(Axis whose nodes are ``values`` — uniform in ``spacing``'s coordinate —, the slice of them): a
    single value is pinned (``_pinned_axis``) and its node alone is taken."""
    if values.size == 1:
        axis, i = _pinned_axis(name, float(values[0]), top)
        return axis, slice(i, i + 1)
    return Axis(name, float(values[0]), float(values[-1]), values.size, spacing), slice(None)


def _kernel_tile(
    stack: SliceStack, cos_t: np.ndarray, thickness: np.ndarray, integrator: Integrator, observer: str, space: str
) -> np.ndarray:
    eta2 = float(stack.film)
    # The η3 tile baked beside the slice's is a base matching the film (r23 = 0 at κ3 = 0): a one-term series.
    eta3_axis, i_eta3 = _pinned_axis("eta3", float(stack.base[0]), MAX_INDEX, partner=eta2)
    kappa3_axis, i_kappa3 = _pinned_axis("kappa3", float(stack.base[1]), np.inf)
    cos_axis, columns = _grid_axis("cos_theta", cos_t, 1.0, "sqrt")
    opd_axis, rows = _grid_axis("opd_nm", 2.0 * eta2 * thickness, MAX_OPD_NM)
    spec = BakeSpec(
        eta2=eta2, eta1=stack.eta1, axes=(cos_axis, opd_axis, eta3_axis, kappa3_axis), observer=observer, space=space
    )
    # Only the rows of the base's κ3 node (at most 2 × 256 × 256 cells), then its η3 tile's columns.
    layout = spec.layout
    (x0, y0), (x1, y1) = layout.texel(0, 0, i_eta3, i_kappa3), layout.texel(0, 0, i_eta3 + 1, i_kappa3 + 1)
    band = integrator.bake_rows(spec, y0, y1)
    return band[rows, x0:x1][:, columns]


def _direct_per_wavelength(
    stack: SliceStack, points: FilmPoints, floor: int, integrator: Integrator, observer: str, space: str
) -> np.ndarray:
    """RGB (P, 3) by the direct quadrature with per-node indices (dispersive stacks), at rule levels
    no lower than ``floor``."""
    ladder = stack.ladder(observer, space)
    levels = np.maximum(_fringe_levels(stack, points, ladder), floor)
    out = np.empty((len(points), 3))
    for level in np.unique(levels):
        cells = np.flatnonzero(levels == level)
        out[cells] = _rule_colour(stack, subset(points, cells), ladder.rule(level), integrator)
    return out


def _fringe_levels(stack: SliceStack, points: FilmPoints, ladder: RuleLadder) -> np.ndarray:
    """The ladder level each point's fringes need: cycles at the film's largest index, |r21·r23| at
    its largest over the visible (both per distinct cos θ: the stack is fixed)."""
    cos_values, row = np.unique(points.cos_theta, return_inverse=True)
    angles = stack.points(cos_values, np.zeros_like(cos_values))
    eta2, eta3, kappa3 = angles.as_column().indices(_SCREEN_NM)
    g2 = normal_admittance(eta2.max(axis=1), 0.0, angles.eta1, angles.cos_theta).real
    cycles = 2.0 * points.thickness_nm * g2[row] * WAVENUMBER_SPAN_PER_NM
    finesse = round_trip_amplitude(angles.eta1[:, None], eta2, eta3, kappa3, angles.cos_theta[:, None]).max(axis=1)
    return ladder.level(cycles, finesse[row])


def _material_level(
    stack: SliceStack, thickness_nm: tuple[float, float], integrator: Integrator, ladder: RuleLadder
) -> int:
    """The coarsest floor that resolves the materials' own spectra (their tables' kinks, which the
    fringe rule does not see): at probe texels spread over the slice (the thinnest and thickest film
    at five angles), each at the level a texel there gets — its fringe level or the floor, the
    larger — agrees with the next finer rule to DISPERSIVE_TOLERANCE / 4. Probes whose level is the
    ladder's last have no finer rule to compare with and do not count."""
    cos_t, d = np.meshgrid(_PROBE_COS, thickness_nm)
    probes = stack.points(cos_t.ravel(), d.ravel())
    fringe, top = _fringe_levels(stack, probes, ladder), len(ladder.counts) - 1
    colours: dict[int, np.ndarray] = {}  # level -> RGB of every probe by that level's rule

    def colour(level: int) -> np.ndarray:
        if level not in colours:
            colours[level] = _rule_colour(stack, probes, ladder.rule(level), integrator)
        return colours[level]

    for floor in range(top):
        levels = np.maximum(fringe, floor)
        compared = [i for i in range(len(probes)) if levels[i] < top]
        change = max((np.max(np.abs(colour(levels[i] + 1)[i] - colour(levels[i])[i])) for i in compared), default=0.0)
        if change <= DISPERSIVE_TOLERANCE / 4:  # margin: the finer rule is not exact
            return floor
    return top


def _rule_colour(stack: SliceStack, points: FilmPoints, rule: SpectralRule, integrator: Integrator) -> np.ndarray:
    """RGB (P, 3) of ``stack`` at ``points`` by one rule, indices per node: summed by the kernel on the
    device (numpy without OpenCL)."""
    kernel = getattr(integrator, "stack_colour", None)
    if kernel is None:
        return spectral_reflectance(points, rule.wavelength_nm)[2] @ rule.weights.T
    node_indices = [v.ravel() for v in stack.points(1.0, 0.0).as_column().indices(rule.wavelength_nm)]
    return kernel(stack.eta1, points.cos_theta, points.thickness_nm, node_indices, rule)
