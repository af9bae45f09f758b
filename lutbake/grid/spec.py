"""Bake plans: the LUT's axes, its tile packing, the spectral rule and the chunks.

A LUT is a 4D grid over (cos θ1, D, η3, κ3) for a film η2 under an ambient
η1. It is packed as a 2D image of tiles: each tile is one (η3, κ3) node and
holds the (cos θ1, D) slice, cos θ1 along x and D along y; tiles go along x
by η3 and along y by κ3. A texel (x, y) is therefore

    x = i_eta3 · N_cos + i_cos,   y = i_kappa3 · N_opd + i_opd.

Axes are uniform, or warped uniform in √v (denser near the low end, where
thin-film colour changes fastest along D and κ3). The η3 axis may instead be
uniform in the base's real admittance √(η3² − (η1 sin θ1)²) between its ends
at each cos θ1 ("admittance"): the base's Fresnel terms are smooth in it, and
its nodes crowd towards η3 = η1 at grazing, where they change fastest in η3;
or uniform in the square root of that admittance ("sqrt-admittance"), which
crowds them harder there: near η3 = η1 at grazing, a film between two
near-total reflections rings, and its colour changes on the scale of cos θ1
in admittance.
Its nodes then depend on the tile's cos θ1 node, so η3 is given per image
column (``eta3_columns``). Chunks are bands of whole image rows, so a grid of
any size bakes and streams in bounded memory.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict, dataclass

import numpy as np

from lutbake.errors import ParameterError
from lutbake.grid.layout import _CHUNK_CELLS, TileLayout
from lutbake.io.names import ADMITTANCE_SPACINGS, INTERPOLATIONS
from lutbake.physics.colorimetry import OBSERVERS, SPACES
from lutbake.physics.optics import normal_admittance, round_trip_amplitude
from lutbake.physics.points import FilmPoints, check_value
from lutbake.spectral.rules import DEFAULT_SAMPLES_PER_CYCLE, WAVENUMBER_SPAN_PER_NM, rule_ladder

__all__ = [
    "Axis",
    "BakeSpec",
    "parse_axis",
    "axis_from_header",
    "AXIS_NAMES",
    "SPACINGS",
    "PRECISIONS",
    "COMPUTE_PRECISIONS",
    "METHODS",
]

AXIS_NAMES = ("cos_theta", "opd_nm", "eta3", "kappa3")
AXIS_UNITS = {"cos_theta": "1", "opd_nm": "nm", "eta3": "1", "kappa3": "1"}
SPACINGS = ("uniform", "sqrt", "root4", "uniform-root4", *ADMITTANCE_SPACINGS)
# "uniform-root4" (format v5): uniform in (1 − g)·v + g·v^¼, g = ROOT4_WEIGHT. On cos θ1 under a corner
# zoom: near grazing, at a fixed node coordinate, D, η3 and κ3 move with √cos θ1, which the ¼ power makes
# a smooth function of the coordinate; towards normal incidence, where a thick film's phase turns with
# cos θ1, it is near uniform.
ROOT4_WEIGHT = 0.5
CORNER_AXES = ("opd_nm", "eta3", "kappa3")
PRECISIONS = ("float", "half")
COMPUTE_PRECISIONS = ("float64", "float32")
METHODS = ("spectral",)
# Budget limits, checked before any work (docs/lut-format.md, "Limits"). Counts are bounded before
# they are multiplied; cells are multiplied as Python integers (no overflow).
MAX_COUNT = 1 << 24
MAX_CELLS = 2_000_000_000
DEFAULT_MEMORY_LIMIT_GIB = 8.0
# Bake rates measured by bench/bench_b1.py on this project's CI CPU (cells per second).
_CELLS_PER_SECOND = {"opencl": 8.5e5, "numpy": 2.4e4}
_BISECTIONS = 64  # Axis.from_unit with a corner: the base coordinate to 2^-64
_NEWTON_STEPS = 60  # the uniform-root4 spacing's inverse: converged to rounding (monotone steps)
CORNER_COS = 1e-5  # where a corner LUT evaluates its cos θ1 = 0 nodes: the limit along each node's curve
SCREEN_CHUNK = 1 << 16  # texels capped_texels screens at once
SERIES_CHUNK = 1 << 16  # columns (or pairs) integrate._series_chunks builds at once
_MIB = 1 << 20
# The memory model (``BakeSpec.memory``): what a bake holds, in bytes, item by item from the code that
# allocates it, with per-item constants fitted to peak RSS measured by bench/bench_memory.py (a process
# that bakes one shape; the allocators keep some freed memory, so these are resident bytes, not the
# arrays' sizes alone); tests/grid/test_memory.py holds the estimate within 1.25x of measured peaks.
MEMORY = {
    # interpreter, numpy, OpenEXR, the colour tables; OpenCL: pyopencl, every registered runtime's library,
    # the running one's compiler, program and self-check, per runtime family (docs/devices.md#memory). A bake
    # measures it once its integrator is up; before that the largest stands for whichever will run.
    "runtime": {"numpy": 48 * _MIB, "opencl": {"pocl": 170 * _MIB, "intel": 270 * _MIB}},
    "tables": 24 * _MIB,  # the closed form's Cauchy table (8.3 MB) on the host and the device
    "column": 192,  # per (cos θ, η3, κ3): the series and rule constants on the device (24 REAL)
    "pair": 56,  # per (cos θ, D): X and e^{i2πXν0} on the device, the plan's term counts, offsets
    "build": 1400,  # per column of the chunk (2^16 at most) integrate._series_chunks builds and copies
    # to the device at a time: the chunk and its temporaries (827 B traced)
    "pair_table": 48 * _MIB,  # the pairs' shared Ŵ(mX), when there are (integrate.PAIR_TABLE_BYTES at most)
    "plan_cell": 12,  # per cell of a band during the plan: the texels left and the series bounds
    "probes": 30 * _MIB,  # the ground truth at the 48 probes (lutbake/spectral/reference.py) ...
    "probes_per_um": 0.52 * _MIB,  # ... and its growth with the thickest film D (finer rules)
    "flight_cell": {"series": 45, "direct": 80},  # per cell of the bands in flight (the one written, the next baking;
    # one where the image is one band): RGB float64 on the host and
    # the device, the lists of texels left (direct: levels)
    "numpy_cell": 168,  # per cell of a band on the numpy path: the stacks, levels and RGB, two bands
    "numpy_chunk": 330,  # per (cell, node) pair of NumpyBackend's optics chunk (2^19 at most)
    "screen": 750 << 16,  # capped_texels: one chunk of 2^16 texels screened and filtered
}


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
        () or (nodes, scale): the grazing corner's zoom (format v5, D, η3 and κ3 only; docs/lut-format.md#the-grazing-corner).
        The coordinate becomes (1 − β)·u + β·H(ρ)/H(ρ_max), β = nodes/(count − 1), H(ρ) = 1 − (1 + ρ)^−¼, with
        ρ the axis's ratio to the incidence: D/(scale·cos θ1), (η3² − η1²)/(scale·(η1 cos θ1)²) or
        2η1κ3/(scale·(η1 cos θ1)²). Near cos θ1 = 0, D = 0, η3 = η1, κ3 = 0 the colour is a function of
        these ratios only, so in this coordinate it has a limit there, which a grid can follow.

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
    corner: tuple = ()

    @property
    def unit(self) -> str:
        return AXIS_UNITS[self.name]

    def values(self, cos_theta=1.0, eta1=1.0) -> np.ndarray:
        """Node values (float64), exact at both ends, at the incidence cos θ1 under the ambient η1 where the
        spacing follows it (a scalar cos θ1 gives (count,); an array of them (count, *their shape))."""
        u = np.linspace(0.0, 1.0, self.count).reshape((-1,) + (1,) * np.ndim(cos_theta))
        v = np.array(self.from_unit(u, cos_theta, eta1), float)
        v[0], v[-1] = self.lo, self.hi
        return v

    def _warp(self, v, inc):
        """The coordinate in which the nodes are uniform, at the incidence ``inc`` = (η1, (η1 cos θ1)²)."""
        if self.spacing == "sqrt":
            return np.sqrt(np.maximum(v, 0.0))
        if self.spacing == "root4":
            return np.sqrt(np.sqrt(np.maximum(v, 0.0)))
        if self.spacing == "uniform-root4":
            return (1.0 - ROOT4_WEIGHT) * v + ROOT4_WEIGHT * np.sqrt(np.sqrt(np.maximum(v, 0.0)))
        if self.spacing in ADMITTANCE_SPACINGS:  # Y3² = (η3 − η1)(η3 + η1) + (η1 cos θ1)²: no cancellation
            root = np.sqrt(np.maximum((v - inc[0]) * (v + inc[0]) + inc[1], 0.0))
            return root if self.spacing == "admittance" else np.sqrt(root)
        return v

    def _unwarp(self, w, inc):
        if self.spacing == "sqrt":
            return w * w
        if self.spacing == "root4":
            return np.square(w * w)
        if self.spacing == "uniform-root4":  # r = v^¼ solves (1 − g) r⁴ + g r = w, convex and increasing in
            g = ROOT4_WEIGHT  # r ≥ 0: Newton's steps from above converge monotonically
            r = np.maximum(np.sqrt(np.sqrt(np.maximum(w, 0.0) / (1.0 - g))), w / g)
            for _ in range(_NEWTON_STEPS):
                r = r - ((1.0 - g) * r**4 + g * r - w) / (4.0 * (1.0 - g) * r**3 + g)
            return np.square(r * r)
        if self.spacing in ADMITTANCE_SPACINGS:  # η3 from η3² = Y3² − (η1 cos θ1)² + η1²
            y2 = w * w if self.spacing == "admittance" else np.square(w * w)
            return np.sqrt(np.maximum(y2 - inc[1] + inc[0] ** 2, 0.0))
        return w

    def _base_unit(self, v, inc):
        a, b = self._warp(np.float64(self.lo), inc), self._warp(np.float64(self.hi), inc)
        return (self._warp(v, inc) - a) / (b - a)

    def _base_value(self, u, inc):
        a, b = self._warp(np.float64(self.lo), inc), self._warp(np.float64(self.hi), inc)
        return self._unwarp(a + (b - a) * u, inc)

    def _zoom(self, v, cos_theta, inc):
        """H(ρ)/H(ρ_max) of the corner: 0 at lo, 1 at hi, and 1 at any v > lo when cos θ1 = 0."""
        b = self._ratio_denominator(cos_theta, inc)
        return _ratio_h(self._ratio_numerator(v, inc[0]), b) / _ratio_h(self._ratio_numerator(self.hi, inc[0]), b)

    def _ratio_numerator(self, v, eta1):
        """a ≥ 0 of the axis's ratio ρ = a/b to the incidence: D (nm), η3² − η1² or 2η1κ3 (the base's admittance
        squared minus (η1 cos θ1)², in size)."""
        v = np.asarray(v, float)
        if self.name == "opd_nm":
            return np.maximum(v, 0.0)
        if self.name == "eta3":
            return np.maximum((v - eta1) * (v + eta1), 0.0)
        return np.maximum(2.0 * eta1 * v, 0.0)

    def _ratio_denominator(self, cos_theta, inc):
        """b of the ratio: scale·cos θ1 (D) or scale·(η1 cos θ1)² (η3, κ3)."""
        return self.corner[1] * (cos_theta if self.name == "opd_nm" else inc[1])

    def value_at_ratio(self, rho, cos_theta, eta1=1.0):
        """The value whose ratio to the incidence cos θ1 is ρ (``_ratio_numerator``'s inverse at a = ρ·b)."""
        cos_theta = np.asarray(cos_theta, float)
        a = rho * self._ratio_denominator(cos_theta, (eta1, np.square(eta1 * cos_theta)))
        if self.name == "opd_nm":
            return a
        return np.sqrt(eta1 * eta1 + a) if self.name == "eta3" else a / (2.0 * eta1)

    def from_unit(self, u, cos_theta=1.0, eta1=1.0):
        """Value at the normalized coordinate u in [0, 1] at the incidence cos θ1 (under the ambient η1):
        in closed form, or with a corner by bisection on the base coordinate (the zoom is increasing)."""
        u, cos_theta = np.asarray(u, float), np.clip(np.asarray(cos_theta, float), 0.0, 1.0)
        inc = (float(eta1), np.square(eta1 * cos_theta))
        if not self.corner:
            return self._base_value(u, inc)
        beta = self.corner[0] / (self.count - 1)
        lo, hi = np.zeros(np.broadcast(u, cos_theta).shape), np.ones(np.broadcast(u, cos_theta).shape)
        for _ in range(_BISECTIONS):
            mid = 0.5 * (lo + hi)
            above = (1.0 - beta) * mid + beta * self._zoom(self._base_value(mid, inc), cos_theta, inc) > u
            lo, hi = np.where(above, lo, mid), np.where(above, mid, hi)
        return self._base_value(0.5 * (lo + hi), inc)

    def to_unit(self, v, cos_theta=1.0, eta1=1.0):
        """Inverse of ``from_unit``: the normalized coordinate in [0, 1] (unclamped) of the value v."""
        v, cos_theta = np.asarray(v, float), np.clip(np.asarray(cos_theta, float), 0.0, 1.0)
        inc = (float(eta1), np.square(eta1 * cos_theta))
        u = self._base_unit(v, inc)
        if not self.corner:
            return u
        beta = self.corner[0] / (self.count - 1)
        return (1.0 - beta) * u + beta * self._zoom(v, cos_theta, inc)

    def resized(self, count: int) -> "Axis":
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

    def describe(self) -> dict:
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


def _ratio_h(a, b):
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


def axis_from_header(record: dict) -> Axis:
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
    if axis.corner:
        _validate_corner(axis, field)
    return axis


def _validate_corner(axis: Axis, field: str) -> None:
    """A corner zoom: on D (from 0), η3 (from η1: checked by BakeSpec) or κ3 (from 0), 1 ≤ nodes ≤ N − 2
    (the base coordinate keeps a share), a finite scale > 0."""
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


@dataclass(frozen=True)
class BakeSpec:
    """Everything that determines a LUT's bytes: the film, the four axes, colour and storage settings.

    Parameters
    ----------
    eta2 : float
        The film's refractive index (constant over wavelength).
    axes : tuple of Axis
        cos_theta, opd_nm, eta3, kappa3, in that order.
    eta1 : float
        The ambient's index (1 = air).
    space, observer : str
        Linear RGB space ('rec709', 'rec2020', 'p3', 'acescg') and CIE observer ('cie1931', 'cie1964').
    precision : str
        Storage: 'half' or 'float'.
    interpolation : str
        How the LUT is sampled, recorded in its header and followed by the sampler and the shader
        includes: 'cubic' (Catmull-Rom in all four axes, 256 texel reads) or 'linear' (4 bilinear
        fetches). The texels are the same; docs/lut-format.md#interpolation.
    compute : str
        Kernel arithmetic: 'float64' or 'float32'.
    method, samples_per_cycle
        The direct quadrature's spectral rule (docs/spectral.md).

    Examples
    --------
    >>> import lutbake
    >>> spec = lutbake.BakeSpec(eta2=1.5, axes=(
    ...     lutbake.Axis("cos_theta", 0.0, 1.0, 32, "sqrt"), lutbake.Axis("opd_nm", 0.0, 3000.0, 128),
    ...     lutbake.Axis("eta3", 1.0, 3.0, 16), lutbake.Axis("kappa3", 0.0, 5.0, 16, "sqrt")), precision="half")
    >>> spec.shape, spec.cells, spec.image_size
    ((32, 128, 16, 16), 1048576, (512, 2048))
    >>> lutbake.BakeSpec(eta2=1.5, axes=spec.axes[:3] + (lutbake.Axis("kappa3", 0.0, 5.0, 1),))
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: kappa3 count 1 is not allowed: need 2 <= N <= ...
    """

    eta2: float
    axes: tuple
    eta1: float = 1.0
    space: str = "rec709"
    observer: str = "cie1931"
    precision: str = "float"
    interpolation: str = "cubic"
    compute: str = "float64"
    method: str = "spectral"
    samples_per_cycle: float = DEFAULT_SAMPLES_PER_CYCLE

    def __post_init__(self):
        check_value("eta1", self.eta1)
        check_value("eta2", self.eta2)
        _choice("space", self.space, SPACES)
        _choice("observer", self.observer, OBSERVERS)
        _choice("precision", self.precision, PRECISIONS)
        _choice("interpolation", self.interpolation, INTERPOLATIONS)
        _choice("compute", self.compute, COMPUTE_PRECISIONS)
        _choice("method", self.method, METHODS)
        if [a.name for a in self.axes] != list(AXIS_NAMES):
            raise ValueError(f"axes must be {', '.join(AXIS_NAMES)} in that order")
        for axis in self.axes:
            validate_axis(axis)
        eta3 = self.axis["eta3"]
        if eta3.spacing in ADMITTANCE_SPACINGS and eta3.lo < self.eta1:
            raise ParameterError(
                "{eta3} " + eta3.spacing + " spacing needs A >= eta1 ({eta1}), got {lo}",
                eta1=f"{self.eta1:g}",
                lo=f"{eta3.lo:g}",
            )
        if eta3.corner and eta3.lo != self.eta1:
            raise ParameterError(
                "{eta3} corner zoom needs A = eta1 ({eta1}), got {lo}", eta1=f"{self.eta1:g}", lo=f"{eta3.lo:g}"
            )
        if self.has_corner and self.axis["cos_theta"].lo != 0.0:
            raise ParameterError(
                "{cos_theta} range must start at 0 under a corner zoom, got {lo}", lo=f"{self.axis['cos_theta'].lo:g}"
            )
        if not 1.0 <= self.samples_per_cycle <= 64.0:
            raise ValueError(f"samples per cycle {self.samples_per_cycle:g} is outside [1, 64]")
        if self.cells > MAX_CELLS:
            raise ValueError(f"grid of {self.cells} cells exceeds the {MAX_CELLS} cell limit: use fewer nodes")

    @property
    def axis(self) -> dict:
        return {a.name: a for a in self.axes}

    @property
    def shape(self) -> tuple:
        return tuple(a.count for a in self.axes)

    @property
    def cells(self) -> int:
        return math.prod(self.shape)

    def memory(self, backend: str = "opencl", integrator: str = "series", runtime_bytes: int = None, plan=None) -> dict:
        """Estimated peak resident memory of baking this spec, bytes, by item (``MEMORY``): ``peak`` is the
        runtime, what persists through the bake, and the larger of its two phases (the plan with the probes
        beside it and the capped texels' screen; the bands), plus the whole image where the file's tiles
        run in another order (``retile``). Before any work the runtime is MEMORY's and
        the shared table and the closed form's table are bounded from the shape; a bake checks again with
        the runtime's resident bytes measured (``runtime_bytes``) and its plan's outcome (``plan``:
        integrate.SeriesStats). That last estimate is within 1.25x of peak RSS measured over several
        shapes (tests/grid/test_memory.py)."""
        from lutbake.spectral.rules import MAX_WAVENUMBER_NODES

        n_cos, n_opd, n_eta3, n_kappa3 = self.shape
        band = min(self.cells, max(_CHUNK_CELLS, self.image_size[0]))  # row_chunks: at least one image row
        exr = band * 9 * (2 if self.precision == "half" else 4)  # stored, its planes and their bytes
        probes = MEMORY["probes"] + MEMORY["probes_per_um"] * self.axis["opd_nm"].hi / 1000.0
        before_work = MEMORY["runtime"]["numpy"] if backend == "numpy" else max(MEMORY["runtime"]["opencl"].values())
        items = {"runtime": runtime_bytes or before_work}
        if backend == "numpy":
            chunk = min(band * MAX_WAVENUMBER_NODES, 1 << 19) * MEMORY["numpy_chunk"]
            items["phases"] = max(probes + MEMORY["screen"], band * MEMORY["numpy_cell"] + exr + chunk)
        else:
            columns, pairs = n_cos * n_eta3 * n_kappa3, n_cos * n_opd
            closed = plan is None or plan.closed_form_texels or plan.direct_texels
            items["tables"] = MEMORY["tables"] if closed else 0
            items["arrays"] = columns * MEMORY["column"] + pairs * MEMORY["pair"]
            shared = integrator == "series" and n_eta3 * n_kappa3 >= 8
            terms = pairs * 512 if plan is None else plan.shared_terms
            items["pair_table"] = min(MEMORY["pair_table"], terms * 48) if shared else 0
            plan = min(columns, SERIES_CHUNK) * MEMORY["build"] + band * MEMORY["plan_cell"] + probes
            if integrator == "direct":
                plan += MEMORY["screen"]
            in_flight = min(self.cells, 2 * band)  # bake.write_lut: band k written while band k + 1 bakes
            items["phases"] = max(plan, in_flight * MEMORY["flight_cell"][integrator] + exr)
        if self.file_layout != self.layout:  # bake.write_lut re-tiles the whole image, as stored, in 3 copies
            items["retile"] = self.cells * 9 * (2 if self.precision == "half" else 4)
        items["peak"] = sum(items.values())
        return items

    def budget(self, backend: str = "auto", integrator: str = "series", runtime_bytes: int = None, plan=None) -> dict:
        """Cells, output bytes, estimated peak memory (``memory``) and bake seconds (per backend), before
        any work. ``backend`` 'auto' takes the larger of the two paths' peaks (it may fall back to numpy)."""
        names = ("opencl", "numpy") if backend == "auto" else (backend,)
        peak = max(self.memory(name, integrator, runtime_bytes, plan)["peak"] for name in names)
        return {
            "cells": self.cells,
            "output_bytes": self.cells * 3 * (2 if self.precision == "half" else 4),
            "peak_memory_bytes": peak,
            "seconds_estimate": {name: self.cells / rate for name, rate in _CELLS_PER_SECOND.items()},
        }

    def check_budget(
        self,
        memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
        backend: str = "auto",
        integrator: str = "series",
        runtime_bytes: int = None,
        plan=None,
    ) -> dict:
        """The budget, or ParameterError when ``memory_limit_gib`` is not a finite number > 0 or the
        estimated peak memory exceeds it."""
        try:
            limit = float(memory_limit_gib)
        except (TypeError, ValueError):
            limit = float("nan")
        if not (math.isfinite(limit) and limit > 0):
            raise ParameterError(
                "{memory_limit_gib} {value} is not allowed: must be a finite number of GiB > 0",
                value=repr(memory_limit_gib),
            )
        b = self.budget(backend, integrator, runtime_bytes, plan)
        if b["peak_memory_bytes"] > limit * (1 << 30):
            raise ParameterError(
                "grid {grid} needs about {need} GiB of memory, over the {limit} GiB limit: use "
                "fewer nodes or raise {memory_limit_gib}",
                grid=" x ".join(map(str, self.shape)),
                need=f"{b['peak_memory_bytes'] / (1 << 30):.1f}",
                limit=f"{limit:g}",
            )
        return b

    @property
    def has_corner(self) -> bool:
        """True when an axis zooms into the grazing corner (format v5)."""
        return any(a.corner for a in self.axes)

    def cos_evaluated(self) -> np.ndarray:
        """cos θ1 at which each cos θ1 node's texels are evaluated: the node's own value, except that under a
        corner zoom the node cos θ1 = 0 holds the limit along each node's curve, reached at CORNER_COS (the
        colour there is a function of the corner's ratios, to O(cos θ1))."""
        cos_t = self.axis["cos_theta"].values()
        if self.has_corner:
            cos_t[cos_t == 0.0] = CORNER_COS
        return cos_t

    def node_values(self, name: str) -> np.ndarray:
        """Node values of axis ``name``: cos θ1 (N_cos,) as evaluated; D, η3, κ3 (N, N_cos), one column per
        cos θ1 node, since the admittance spacings and the corner zoom follow the incidence."""
        cos_t = self.cos_evaluated()
        if name == "cos_theta":
            return cos_t
        axis = self.axis[name]
        v = np.array(np.broadcast_to(axis.values(cos_t, self.eta1), (axis.count, cos_t.size)))
        if axis.corner:  # a zoom's cos θ1 axis starts at 0 (validated): its first column is the limit
            v[:, 0] = self._grazing_column(axis)
        return v

    def _grazing_column(self, axis: Axis) -> np.ndarray:
        """Node values of a corner axis in the cos θ1 = 0 column, evaluated at CORNER_COS: there the zoom is
        H(ρ)/H(ρ_max) → H(ρ), so node u < β holds the ratio ρ = (1 − h)^−4 − 1, h = u/β, set exactly
        (the bisection would reach it only to O(√CORNER_COS)); nodes u ≥ β hold total reflection
        (``grazing_white``) and keep the value the bisection gives."""
        h = np.minimum(np.arange(axis.count) / axis.corner[0], 1.0)
        with np.errstate(divide="ignore"):
            rho = (1.0 - h) ** -4.0 - 1.0
        return np.where(h < 1.0, axis.value_at_ratio(rho, CORNER_COS, self.eta1), axis.values(CORNER_COS, self.eta1))

    def grazing_white(self, y0: int, y1: int) -> np.ndarray:
        """Texels of rows [y0, y1) that hold total reflection, (rows, width) bool: in the cos θ1 = 0 column of a
        corner zoom, every node at or past the zoom's share on some axis (ρ → ∞ along its curve, so R → 1,
        as the ground truth has it at cos θ1 = 0). The integrators set them to exactly 1."""
        width, _ = self.image_size
        i_cos, i_opd, i_eta3, i_kappa3 = self.layout.nodes(np.arange(width)[None, :], np.arange(y0, y1)[:, None])
        white = np.zeros((y1 - y0, width), bool)
        for axis, index in zip(self.axes[1:], (i_opd, i_eta3, i_kappa3)):
            if axis.corner:
                white |= index >= axis.corner[0]
        return white & (i_cos == 0)

    def eta3_columns(self) -> np.ndarray:
        """η3 of each image column, in column order (layout.TileLayout: η3 nodes at the column's cos θ1 node)."""
        return np.ascontiguousarray(self.node_values("eta3")).ravel()

    @property
    def layout(self) -> TileLayout:
        """How the integrators pack the grid into rows of texels, η3 along x (lutbake/grid/layout.py: the one statement of
        the tile formula); the file's packing may differ (``file_layout``)."""
        return TileLayout(*self.shape)

    @property
    def file_layout(self) -> TileLayout:
        """How the LUT file packs the grid (TileLayout.for_grid: κ3 along x where η3 would pass 4096 texels)."""
        return TileLayout.for_grid(self.shape)

    @property
    def image_size(self) -> tuple:
        """(width, height) of the integrators' packed image in texels (``layout``)."""
        return self.layout.size

    @property
    def ladder(self):
        return rule_ladder(self.samples_per_cycle, self.observer, self.space)

    def _fringes(self, cos_theta, opd_nm, eta3, kappa3):
        """(cycles over the visible span, |r21·r23|) of each texel."""
        g2 = normal_admittance(self.eta2, 0.0, self.eta1, cos_theta)
        cycles = np.asarray(opd_nm) * g2.real / self.eta2 * WAVENUMBER_SPAN_PER_NM
        return cycles, round_trip_amplitude(self.eta1, self.eta2, eta3, kappa3, cos_theta)

    def cell_levels(self, cos_theta, opd_nm, eta3, kappa3) -> np.ndarray:
        """Spectral rule level of each texel (spectral.RuleLadder.level), float64 on the host."""
        return self.ladder.level(*self._fringes(cos_theta, opd_nm, eta3, kappa3))

    def row_levels(self, y0: int, y1: int) -> np.ndarray:
        """Levels of every texel in rows [y0, y1), flat: equal to cell_levels on cell_params,
        but |r21·r23| is evaluated once per (x, κ3) and cycles once per (cos θ, D)."""
        width, _ = self.image_size
        cos_t, opd, kappa3 = (self.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
        i_cos, i_opd, _, k_index = self.layout.nodes(np.arange(width), np.arange(y0, y1))
        kappa_rows = np.unique(k_index)
        rt = round_trip_amplitude(
            self.eta1, self.eta2, self.eta3_columns()[None, :], kappa3[kappa_rows][:, i_cos], cos_t[i_cos][None, :]
        )
        rt_rows = rt[np.searchsorted(kappa_rows, k_index)]
        g2 = normal_admittance(self.eta2, 0.0, self.eta1, cos_t[i_cos]).real
        cycles = opd[i_opd][:, i_cos] * (g2 / self.eta2 * WAVENUMBER_SPAN_PER_NM)[None, :]
        return self.ladder.level(cycles, rt_rows).ravel()

    def texel_stacks(self, coords) -> FilmPoints:
        """Film stacks of this spec's film at texel coordinates (arrays in axis order: cos θ1, D, η3,
        κ3), unchecked: for coordinates this validated spec produced (its grid, its cells)."""
        return FilmPoints.texels(eta1=self.eta1, eta2=self.eta2, **dict(zip((a.name for a in self.axes), coords)))

    def truncation_estimate(self, cos_theta, opd_nm, eta3, kappa3) -> np.ndarray:
        """Bound on the spectral truncation error of texels past the ladder's cap (else 0). At grazing
        incidence (cos θ1 = 0) R ≡ 1 at every wavenumber, which any rule integrates exactly: 0 there."""
        bound = self.ladder.truncation_estimate(*self._fringes(cos_theta, opd_nm, eta3, kappa3))
        return np.where(np.asarray(cos_theta) > 0.0, bound, 0.0)

    def capped_texels(self, limit: int = 64, keep=None) -> tuple:
        """Texels past the ladder's cap (of those for which ``keep(texels)`` is true, given it): (count,
        largest bound, the ``limit`` worst as (cos θ, D, η3, κ3) arrays).

        Cycles, hence the need for nodes and the bound, grow with D, so each
        (image column, κ3) pair is screened at its largest D first; screened and expanded a chunk at a
        time, so memory stays bounded (SCREEN_CHUNK texels) whatever the grid.
        """
        cos_nodes, opd, kappa_nodes = (self.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
        width, (n_opd, n_kappa3) = self.image_size[0], (opd.shape[0], kappa_nodes.shape[0])
        eta3_columns = self.eta3_columns()
        count, best, worst = 0, 0.0, tuple(np.empty(0) for _ in range(4))
        worst_bound = np.empty(0)
        for start in range(0, width * n_kappa3, SCREEN_CHUNK):
            column = np.arange(start, min(start + SCREEN_CHUNK, width * n_kappa3))  # x major, κ3 minor
            x = column // n_kappa3
            i_cos = self.layout.nodes(x, 0)[0]
            cos_t, eta3, kappa3 = cos_nodes[i_cos], eta3_columns[x], kappa_nodes[column % n_kappa3, i_cos]
            cols = np.flatnonzero(self.truncation_estimate(cos_t, np.full(cos_t.shape, opd[-1, 0]), eta3, kappa3))
            step = max(1, SCREEN_CHUNK // n_opd)
            for c in range(0, cols.size, step):
                sub = cols[c : c + step]
                params = (
                    np.repeat(cos_t[sub], n_opd),
                    opd[:, i_cos[sub]].T.ravel(),
                    np.repeat(eta3[sub], n_opd),
                    np.repeat(kappa3[sub], n_opd),
                )
                bound = self.truncation_estimate(*params)
                mask = bound > 0
                if keep is not None and mask.any():
                    mask[mask] = keep(tuple(p[mask] for p in params))
                count += int(mask.sum())
                best = max(best, float(bound[mask].max(initial=0.0)))
                # the worst so far, in grid order among equals (a stable sort over what came first)
                worst_bound = np.concatenate([worst_bound, bound[mask]])
                worst = tuple(np.concatenate([w, p[mask]]) for w, p in zip(worst, params))
                keep_order = np.argsort(-worst_bound, kind="stable")[:limit]
                worst_bound, worst = worst_bound[keep_order], tuple(w[keep_order] for w in worst)
        return count, best, worst

    def row_chunks(self, chunk_cells: int = _CHUNK_CELLS):
        """Bands [y0, y1) of image rows, each about ``chunk_cells`` cells."""
        return self.layout.row_chunks(chunk_cells)

    def cell_params(self, y0: int, y1: int):
        """(cos θ1, D, η3, κ3) of every texel in rows [y0, y1), each (y1 − y0, width)."""
        width, _ = self.image_size
        i_cos, i_opd, _, i_kappa3 = self.layout.nodes(np.arange(width)[None, :], np.arange(y0, y1)[:, None])
        shape = (y1 - y0, width)
        cos_t, opd, kappa3 = (self.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
        return (
            np.broadcast_to(cos_t[i_cos], shape),
            np.broadcast_to(opd[i_opd, i_cos], shape),
            np.broadcast_to(self.eta3_columns(), shape),
            np.broadcast_to(kappa3[i_kappa3, i_cos], shape),
        )

    def describe(self) -> dict:
        """The inputs that define the LUT (hashed into ``content_hash``)."""
        d = asdict(self)
        d["axes"] = [a.describe() for a in self.axes]
        d["spectral_counts"] = self.ladder.counts
        return d

    @property
    def content_hash(self) -> str:
        from lutbake import __version__

        text = json.dumps({"spec": self.describe(), "lutbake": __version__}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def _choice(name, value, allowed):
    if value not in allowed:
        raise ValueError(f"{name} {value!r} is not one of {', '.join(allowed)}")
