"""LUT axes: the nodes along one axis of a grid, and the text and header records that describe them.

An axis holds ``count`` nodes from ``lo`` to ``hi``, uniform in its spacing's coordinate: the value itself,
√v or v^¼ (denser near the low end, where thin-film colour changes fastest along D and κ3), or for η3 the
base's real admittance √(η3² − (η1 sin θ1)²) or its square root, which follow the incidence. A corner zoom
(format v5) crowds nodes of D, η3 or κ3 into the grazing corner along their ratio to the incidence
(docs/lut-format.md#the-grazing-corner). ``parse_axis`` reads the command line's A:B:N[:SPACING[:NODES:SCALE]],
``validate_axis`` checks an axis and ``axis_from_header`` reads a LUT header's record; BakeSpec
(lutbake/grid/spec.py) holds four of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from lutbake.errors import ParameterError
from lutbake.io.names import ADMITTANCE_SPACINGS
from lutbake.physics.points import check_value

__all__ = ["Axis", "parse_axis", "validate_axis", "axis_from_header", "AXIS_NAMES", "SPACINGS"]

AXIS_NAMES = ("cos_theta", "opd_nm", "eta3", "kappa3")
AXIS_UNITS = {"cos_theta": "1", "opd_nm": "nm", "eta3": "1", "kappa3": "1"}
SPACINGS = ("uniform", "sqrt", "root4", "uniform-root4", *ADMITTANCE_SPACINGS)
# "uniform-root4" (format v5): uniform in (1 − g)·v + g·v^¼, g = ROOT4_WEIGHT. On cos θ1 under a corner
# zoom: near grazing, at a fixed node coordinate, D, η3 and κ3 move with √cos θ1, which the ¼ power makes
# a smooth function of the coordinate; towards normal incidence, where a thick film's phase turns with
# cos θ1, it is near uniform.
ROOT4_WEIGHT = 0.5
CORNER_AXES = ("opd_nm", "eta3", "kappa3")
# Budget limit, checked before any work (docs/lut-format.md, "Limits").
MAX_COUNT = 1 << 24
_BISECTIONS = 64  # Axis.from_unit with a corner: the base coordinate to 2^-64
_NEWTON_STEPS = 60  # the uniform-root4 spacing's inverse: converged to rounding (monotone steps)
# The incidence a spacing follows: (η1, (η1 cos θ1)²), the second a scalar or an array of them.
_Incidence = tuple[float, np.ndarray]


@dataclass(frozen=True)
class Axis:
    """One LUT axis: ``count`` nodes from ``lo`` to ``hi``, uniform in the spacing's coordinate.

    Parameters
    ----------
    name : str
        'cos_theta' (cosine of the angle of incidence), 'opd_nm' (D = 2·η2·d, nm), 'eta3' or 'kappa3'.
    lo, hi : float
        The range, in the axis's unit.
    count : int
        Nodes, including both ends (2 ≤ count).
    spacing : str
        'uniform'; 'sqrt' (uniform in √value: nodes crowd towards lo); 'root4' (uniform in value^¼:
        crowding harder, cos θ's towards grazing); 'uniform-root4' (uniform in (value + value^¼)/2:
        near uniform at 1, ¼ power near 0; cos θ1 of a corner zoom); 'admittance' (η3 only: uniform in
        √(η3² − (η1 sin θ1)²) at each cos θ1 node, crowding towards η3 = η1 at grazing);
        'sqrt-admittance' (η3 only: uniform in the square root of that admittance, crowding harder).
    corner : tuple
        () or (nodes, scale): the grazing corner's zoom (format v5, D, η3 and κ3 only;
        docs/lut-format.md#the-grazing-corner). The coordinate becomes (1 − β)·u + β·H(ρ)/H(ρ_max),
        β = nodes/(count − 1), H(ρ) = 1 − (1 + ρ)^−¼, with ρ the axis's ratio to the incidence:
        D/(scale·cos θ1), (η3² − η1²)/(scale·(η1 cos θ1)²) or 2η1κ3/(scale·(η1 cos θ1)²). Near cos θ1 = 0,
        D = 0, η3 = η1, κ3 = 0 the colour is a function of these ratios only, so in this coordinate it has a
        limit there, which a grid can follow.

    Examples
    --------
    >>> import lutbake
    >>> lutbake.Axis("cos_theta", 0.0, 1.0, 5, "sqrt").values().tolist()
    [0.0, 0.0625, 0.25, 0.5625, 1.0]
    """

    name: str
    lo: float
    hi: float
    count: int
    spacing: str = "uniform"
    corner: tuple[int, float] | tuple[()] = ()

    @property
    def unit(self) -> str:
        return AXIS_UNITS[self.name]

    def values(self, cos_theta: npt.ArrayLike = 1.0, eta1: float = 1.0) -> np.ndarray:
        """Node values (float64), exact at both ends, at the incidence cos θ1 under the ambient η1 where the
        spacing follows it (a scalar cos θ1 gives (count,); an array of them (count, *their shape))."""
        u = np.linspace(0.0, 1.0, self.count).reshape((-1,) + (1,) * np.ndim(cos_theta))
        v = np.array(self.from_unit(u, cos_theta, eta1), float)
        v[0], v[-1] = self.lo, self.hi
        return v

    def _base_unit(self, v: np.ndarray, inc: _Incidence) -> np.ndarray | np.float64:
        a, b = _warp(self.spacing, np.float64(self.lo), inc), _warp(self.spacing, np.float64(self.hi), inc)
        return (_warp(self.spacing, v, inc) - a) / (b - a)

    def _base_value(self, u: np.ndarray, inc: _Incidence) -> np.ndarray | np.float64:
        a, b = _warp(self.spacing, np.float64(self.lo), inc), _warp(self.spacing, np.float64(self.hi), inc)
        return _unwarp(self.spacing, a + (b - a) * u, inc)

    def _zoom(self, v: npt.ArrayLike, cos_theta: np.ndarray, inc: _Incidence) -> np.ndarray:
        """H(ρ)/H(ρ_max) of the corner: 0 at lo, 1 at hi, and 1 at any v > lo when cos θ1 = 0."""
        b = self._ratio_denominator(cos_theta, inc)
        return _ratio_h(self._ratio_numerator(v, inc[0]), b) / _ratio_h(self._ratio_numerator(self.hi, inc[0]), b)

    def _ratio_numerator(self, value: npt.ArrayLike, eta1: float) -> np.ndarray:
        """a ≥ 0 of the axis's ratio ρ = a/b to the incidence: D (nm), η3² − η1² or 2η1κ3 (the base's admittance
        squared minus (η1 cos θ1)², in size)."""
        v = np.asarray(value, float)
        if self.name == "opd_nm":
            return np.maximum(v, 0.0)
        if self.name == "eta3":
            return np.maximum((v - eta1) * (v + eta1), 0.0)
        return np.maximum(2.0 * eta1 * v, 0.0)

    def _ratio_denominator(self, cos_theta: np.ndarray, inc: _Incidence) -> np.ndarray:
        """b of the ratio: scale·cos θ1 (D) or scale·(η1 cos θ1)² (η3, κ3)."""
        if not self.corner:
            raise ValueError(f"axis {self.name} has no corner zoom, so no ratio to the incidence")
        return self.corner[1] * (cos_theta if self.name == "opd_nm" else inc[1])

    def value_at_ratio(
        self, rho: npt.ArrayLike, cos_theta: npt.ArrayLike, eta1: float = 1.0
    ) -> np.ndarray | np.float64:
        """The value whose ratio to the incidence cos θ1 is ρ (``_ratio_numerator``'s inverse at a = ρ·b)."""
        cos_t = np.asarray(cos_theta, float)
        a = np.asarray(rho, float) * self._ratio_denominator(cos_t, (eta1, np.square(eta1 * cos_t)))
        if self.name == "opd_nm":
            return a
        return np.sqrt(eta1 * eta1 + a) if self.name == "eta3" else a / (2.0 * eta1)

    def from_unit(self, u: npt.ArrayLike, cos_theta: npt.ArrayLike = 1.0, eta1: float = 1.0) -> np.ndarray | np.float64:
        """Value at the normalized coordinate u in [0, 1] at the incidence cos θ1 (under the ambient η1):
        in closed form, or with a corner by bisection on the base coordinate (the zoom is increasing)."""
        unit, cos_t = np.asarray(u, float), np.clip(np.asarray(cos_theta, float), 0.0, 1.0)
        inc = (float(eta1), np.square(eta1 * cos_t))
        if not self.corner:
            return self._base_value(unit, inc)
        beta = self.corner[0] / (self.count - 1)
        lo, hi = np.zeros(np.broadcast(unit, cos_t).shape), np.ones(np.broadcast(unit, cos_t).shape)
        # _zoom and _base_value with what does not change between bisections computed once (same values)
        b = self._ratio_denominator(cos_t, inc)
        h_max = _ratio_h(self._ratio_numerator(self.hi, inc[0]), b)
        w_lo, w_hi = _warp(self.spacing, np.float64(self.lo), inc), _warp(self.spacing, np.float64(self.hi), inc)
        for _ in range(_BISECTIONS):
            mid = 0.5 * (lo + hi)
            value = _unwarp(self.spacing, w_lo + (w_hi - w_lo) * mid, inc)
            above = (1.0 - beta) * mid + beta * (_ratio_h(self._ratio_numerator(value, inc[0]), b) / h_max) > unit
            lo, hi = np.where(above, lo, mid), np.where(above, mid, hi)
        return self._base_value(0.5 * (lo + hi), inc)

    def to_unit(self, v: npt.ArrayLike, cos_theta: npt.ArrayLike = 1.0, eta1: float = 1.0) -> np.ndarray | np.float64:
        """Inverse of ``from_unit``: the normalized coordinate in [0, 1] (unclamped) of the value v."""
        value, cos_t = np.asarray(v, float), np.clip(np.asarray(cos_theta, float), 0.0, 1.0)
        inc = (float(eta1), np.square(eta1 * cos_t))
        u = self._base_unit(value, inc)
        if not self.corner:
            return u
        beta = self.corner[0] / (self.count - 1)
        return (1.0 - beta) * u + beta * self._zoom(value, cos_t, inc)

    def resized(self, count: int) -> Axis:
        """This axis with ``count`` nodes; a corner zoom keeps its share of them (at least 1, at most N − 2)."""
        corner = self.corner
        if corner:
            nodes = int(round(corner[0] * (count - 1) / (self.count - 1)))
            corner = (min(max(nodes, 1), max(count - 2, 1)), corner[1])
        return Axis(self.name, self.lo, self.hi, count, self.spacing, corner)

    def flag(self) -> str:
        """The axis as the command line takes it: A:B:N[:SPACING[:CORNER_NODES:CORNER_SCALE]]."""
        text = f"{self.lo:g}:{self.hi:g}:{self.count}"
        if self.spacing != "uniform" or self.corner:
            text += f":{self.spacing}"
        if self.corner:
            text += f":{self.corner[0]}:{self.corner[1]:g}"
        return text

    def describe(self) -> dict[str, Any]:
        """The header's record of this axis (``axis_from_header``'s input)."""
        out = {
            "name": self.name,
            "unit": self.unit,
            "min": self.lo,
            "max": self.hi,
            "count": self.count,
            "spacing": self.spacing,
        }
        if self.corner:
            out["corner"] = {"nodes": self.corner[0], "scale": self.corner[1]}
        return out


def _warp(spacing: str, v: np.ndarray | np.float64, inc: _Incidence) -> np.ndarray | np.float64:
    """The coordinate in which a ``spacing``'s nodes are uniform, at the incidence ``inc`` = (η1, (η1 cos θ1)²)."""
    if spacing == "sqrt":
        return np.sqrt(np.maximum(v, 0.0))
    if spacing == "root4":
        return np.sqrt(np.sqrt(np.maximum(v, 0.0)))
    if spacing == "uniform-root4":
        return (1.0 - ROOT4_WEIGHT) * v + ROOT4_WEIGHT * np.sqrt(np.sqrt(np.maximum(v, 0.0)))
    if spacing in ADMITTANCE_SPACINGS:  # Y3² = (η3 − η1)(η3 + η1) + (η1 cos θ1)²: no cancellation
        root = np.sqrt(np.maximum((v - inc[0]) * (v + inc[0]) + inc[1], 0.0))
        return root if spacing == "admittance" else np.sqrt(root)
    return v


def _unwarp(spacing: str, w: np.ndarray | np.float64, inc: _Incidence) -> np.ndarray | np.float64:
    """``_warp``'s inverse: the value at the coordinate w."""
    if spacing == "sqrt":
        return w * w
    if spacing == "root4":
        return np.square(w * w)
    if spacing == "uniform-root4":  # r = v^¼ solves (1 − g) r⁴ + g r = w, convex and increasing in
        g = ROOT4_WEIGHT  # r ≥ 0: Newton's steps from above converge monotonically
        r = np.maximum(np.sqrt(np.sqrt(np.maximum(w, 0.0) / (1.0 - g))), w / g)
        for _ in range(_NEWTON_STEPS):
            r = r - ((1.0 - g) * r**4 + g * r - w) / (4.0 * (1.0 - g) * r**3 + g)
        return np.square(r * r)
    if spacing in ADMITTANCE_SPACINGS:  # η3 from η3² = Y3² − (η1 cos θ1)² + η1²
        y2 = w * w if spacing == "admittance" else np.square(w * w)
        return np.sqrt(np.maximum(y2 - inc[1] + inc[0] ** 2, 0.0))
    return w


def _ratio_h(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """H = 1 − (1 + ρ)^−¼ of the ratio ρ = a/b (a, b ≥ 0), written with q = b/(a + b) as
    (a/(a + b))/((1 + √q)(1 + q^¼)), which does not cancel at small ρ; 1 where a = b = 0, which happens only
    at grazing (b ∝ cos θ1), where lutbake's ground truth reflects totally whatever the stack. Near ρ = 0
    H ≈ ρ/4, so the colour, quadratic in the ratios there, stays quadratic in the node coordinate; at
    ρ → ∞ 1 − R falls as (1 − H)² or faster, so R meets 1 without a kink."""
    total = np.asarray(a + b, float)
    empty = total == 0
    safe = np.where(empty, 1.0, total)
    q = b / safe
    return (a / safe + empty) / ((1.0 + np.sqrt(q)) * (1.0 + np.sqrt(np.sqrt(q))))


def axis_from_header(record: dict[str, Any]) -> Axis:
    """The Axis a LUT header's axis record describes (``Axis.describe``'s inverse)."""
    corner = record.get("corner")
    return Axis(
        record["name"],
        record["min"],
        record["max"],
        record["count"],
        record["spacing"],
        (corner["nodes"], corner["scale"]) if corner else (),
    )


def parse_axis(name: str, text: str) -> Axis:
    """Parse 'A:B:N', 'A:B:N:SPACING' or 'A:B:N:SPACING:CORNER_NODES:CORNER_SCALE' into a validated Axis."""
    parts = text.split(":")
    if len(parts) not in (3, 4, 6):
        raise ParameterError(
            f"{{{name}}} {{text}} is not A:B:N, A:B:N:SPACING or A:B:N:SPACING:NODES:SCALE", text=repr(text)
        )
    try:
        lo, hi = float(parts[0]), float(parts[1])
        count = int(parts[2])
        corner = (int(parts[4]), float(parts[5])) if len(parts) == 6 else ()
    except ValueError:
        raise ParameterError(
            f"{{{name}}} {{text}}: A, B and SCALE must be numbers, N and NODES integers", text=repr(text)
        ) from None
    spacing = parts[3] if len(parts) >= 4 else "uniform"
    return validate_axis(Axis(name, lo, hi, count, spacing, corner))


def validate_axis(axis: Axis) -> Axis:
    """``axis``, or ParameterError naming the axis (its parameter name) and what is allowed."""
    field = f"{{{axis.name}}}"
    for v in (axis.lo, axis.hi):
        try:
            check_value(axis.name, v)
        except ValueError as exc:
            raise ParameterError(field + ": {detail}", detail=str(exc)) from None
    if not axis.hi > axis.lo:
        raise ParameterError(
            field + " range {range} is empty or reversed: need A < B", range=f"{axis.lo:g}:{axis.hi:g}"
        )
    if not 2 <= axis.count <= MAX_COUNT:
        raise ParameterError(
            field + " count {count} is not allowed: need 2 <= N <= {most}", count=axis.count, most=MAX_COUNT
        )
    if axis.spacing not in SPACINGS:
        raise ParameterError(
            field + " spacing {spacing} is not one of {allowed}",
            spacing=repr(axis.spacing),
            allowed=", ".join(SPACINGS),
        )
    if axis.spacing in ADMITTANCE_SPACINGS and axis.name != "eta3":
        raise ParameterError(field + f" spacing {axis.spacing!r} is allowed only on {{eta3}}")
    _validate_corner(axis, field)
    return axis


def _validate_corner(axis: Axis, field: str) -> None:
    """A corner zoom: on D (from 0), η3 (from η1: checked by BakeSpec) or κ3 (from 0), 1 ≤ nodes ≤ N − 2
    (the base coordinate keeps a share), a finite scale > 0; nothing to check without one."""
    if not axis.corner:
        return
    nodes, scale = axis.corner
    if axis.name not in CORNER_AXES:
        raise ParameterError(
            field + " has no grazing corner: a corner zoom is allowed on {allowed}", allowed=", ".join(CORNER_AXES)
        )
    if axis.name != "eta3" and axis.lo != 0.0:
        raise ParameterError(field + " corner zoom needs A = 0, got {lo}", lo=f"{axis.lo:g}")
    if not (isinstance(nodes, int) and 1 <= nodes <= axis.count - 2):
        raise ParameterError(
            field + " corner nodes {nodes} is not allowed: need 1 <= nodes <= N - 2 = {most} "
            "(Axis.resized(N) keeps a zoom's share of the nodes)",
            nodes=repr(nodes),
            most=axis.count - 2,
        )
    if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
        raise ParameterError(
            field + " corner scale {scale} is not allowed: need a finite number > 0", scale=repr(scale)
        )
