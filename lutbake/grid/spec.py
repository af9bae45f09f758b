"""The bake spec: everything that determines a LUT's bytes, its film, its four axes and its settings.

A LUT is a 4D grid over (cos θ1, D, η3, κ3) for a film η2 under an ambient η1, each axis an Axis
(lutbake/grid/axis.py). It is packed as a 2D image of tiles: each tile is one (η3, κ3) node and
holds the (cos θ1, D) slice, cos θ1 along x and D along y; tiles go along x by η3 and along y by κ3
(lutbake/grid/layout.py, where a file may swap them). A texel (x, y) is therefore

    x = i_eta3 · N_cos + i_cos,   y = i_kappa3 · N_opd + i_opd.

BakeSpec holds what is baked (the film, the axes, the colour space and observer, storage and kernel
precision, the interpolation rule and the spectral rule) and checks it. What follows from it lives beside
it, each module a stage a bake asks in turn, and BakeSpec's methods of the same names call them: where its
texels are and the bands of rows it bakes (lutbake/grid/texels.py), the spectral rule each texel needs and
its truncation bound (lutbake/grid/truncation.py), and its budget of memory and time
(lutbake/grid/memory.py).
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Callable, Collection, Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from lutbake.errors import ParameterError
from lutbake.grid import memory as memory_model
from lutbake.grid import texels, truncation
from lutbake.grid.axis import AXIS_NAMES, SPACINGS, Axis, axis_from_header, parse_axis, validate_axis
from lutbake.grid.layout import _CHUNK_CELLS, TileLayout
from lutbake.grid.memory import Budget, PlanOutcome
from lutbake.io.names import ADMITTANCE_SPACINGS, INTERPOLATIONS
from lutbake.physics.colorimetry import OBSERVERS, SPACES
from lutbake.physics.points import FilmPoints, check_value
from lutbake.spectral.rules import DEFAULT_SAMPLES_PER_CYCLE, RuleLadder, rule_ladder

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

PRECISIONS = ("float", "half")
COMPUTE_PRECISIONS = ("float64", "float32")
METHODS = ("spectral",)
# Budget limit, checked before any work (docs/lut-format.md, "Limits"); cells are multiplied as Python
# integers (no overflow), after each axis's count is bounded (axis.MAX_COUNT).
MAX_CELLS = 2_000_000_000


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
    axes: tuple[Axis, ...]
    eta1: float = 1.0
    space: str = "rec709"
    observer: str = "cie1931"
    precision: str = "float"
    interpolation: str = "cubic"
    compute: str = "float64"
    method: str = "spectral"
    samples_per_cycle: float = DEFAULT_SAMPLES_PER_CYCLE

    def __post_init__(self) -> None:
        _check_spec(self)

    @property
    def axis(self) -> dict[str, Axis]:
        return {a.name: a for a in self.axes}

    @property
    def shape(self) -> tuple[int, int, int, int]:
        n_cos, n_opd, n_eta3, n_kappa3 = (a.count for a in self.axes)
        return n_cos, n_opd, n_eta3, n_kappa3

    @property
    def cells(self) -> int:
        return math.prod(self.shape)

    @property
    def has_corner(self) -> bool:
        """True when an axis zooms into the grazing corner (format v5)."""
        return any(a.corner for a in self.axes)

    @property
    def layout(self) -> TileLayout:
        """How the integrators pack the grid into rows of texels, η3 along x (lutbake/grid/layout.py: the one
        statement of the tile formula); the file's packing may differ (``file_layout``)."""
        return TileLayout(*self.shape)

    @property
    def file_layout(self) -> TileLayout:
        """How the LUT file packs the grid (TileLayout.for_grid: κ3 along x where η3 would pass 4096 texels)."""
        return TileLayout.for_grid(self.shape)

    @property
    def image_size(self) -> tuple[int, int]:
        """(width, height) of the integrators' packed image in texels (``layout``)."""
        return self.layout.size

    @property
    def ladder(self) -> RuleLadder:
        return rule_ladder(self.samples_per_cycle, self.observer, self.space)

    def row_chunks(self, chunk_cells: int = _CHUNK_CELLS) -> list[tuple[int, int]]:
        """Bands [y0, y1) of image rows, each about ``chunk_cells`` cells."""
        return self.layout.row_chunks(chunk_cells)

    def texel_stacks(self, coords: Iterable[npt.ArrayLike]) -> FilmPoints:
        """Film stacks of this spec's film at texel coordinates (arrays in axis order: cos θ1, D, η3,
        κ3), unchecked: for coordinates this validated spec produced (its grid, its cells)."""
        return FilmPoints.texels(eta1=self.eta1, eta2=self.eta2, **dict(zip((a.name for a in self.axes), coords)))

    # What follows from the spec, computed beside it: each method is the function of the same name there.
    def node_values(self, name: str) -> np.ndarray:
        """Node values of axis ``name`` (lutbake/grid/texels.py)."""
        return texels.node_values(self, name)

    def eta3_columns(self) -> np.ndarray:
        """η3 of each image column (lutbake/grid/texels.py)."""
        return texels.eta3_columns(self)

    def cell_params(self, y0: int, y1: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(cos θ1, D, η3, κ3) of every texel in rows [y0, y1) (lutbake/grid/texels.py)."""
        return texels.cell_params(self, y0, y1)

    def grazing_white(self, y0: int, y1: int) -> np.ndarray:
        """Texels of rows [y0, y1) that hold total reflection (lutbake/grid/texels.py)."""
        return texels.grazing_white(self, y0, y1)

    def cell_levels(
        self, cos_theta: npt.ArrayLike, opd_nm: npt.ArrayLike, eta3: npt.ArrayLike, kappa3: npt.ArrayLike
    ) -> np.ndarray:
        """Spectral rule level of each texel (lutbake/grid/truncation.py)."""
        return truncation.cell_levels(self, cos_theta, opd_nm, eta3, kappa3)

    def row_levels(self, y0: int, y1: int) -> np.ndarray:
        """Levels of every texel in rows [y0, y1), flat (lutbake/grid/truncation.py)."""
        return truncation.row_levels(self, y0, y1)

    def truncation_estimate(
        self, cos_theta: npt.ArrayLike, opd_nm: npt.ArrayLike, eta3: npt.ArrayLike, kappa3: npt.ArrayLike
    ) -> np.ndarray:
        """Bound on the spectral truncation error of each texel (lutbake/grid/truncation.py)."""
        return truncation.truncation_estimate(self, cos_theta, opd_nm, eta3, kappa3)

    def capped_texels(
        self, limit: int = 64, keep: Callable[[tuple[np.ndarray, ...]], np.ndarray] | None = None
    ) -> tuple[int, float, tuple[np.ndarray, ...]]:
        """Texels past the ladder's cap: (count, largest bound, the worst) (lutbake/grid/truncation.py)."""
        return truncation.capped_texels(self, limit, keep)

    def memory(
        self,
        backend: str = "opencl",
        integrator: str = "series",
        runtime_bytes: int | None = None,
        plan: PlanOutcome | None = None,
    ) -> dict[str, float]:
        """Estimated peak resident memory of baking this spec, by item (lutbake/grid/memory.py)."""
        return memory_model.estimate_memory(self, backend, integrator, runtime_bytes, plan)

    def budget(
        self,
        backend: str = "auto",
        integrator: str = "series",
        runtime_bytes: int | None = None,
        plan: PlanOutcome | None = None,
    ) -> Budget:
        """Cells, output bytes, peak memory and bake seconds, before any work (lutbake/grid/memory.py)."""
        return memory_model.budget(self, backend, integrator, runtime_bytes, plan)

    def check_budget(
        self,
        memory_limit_gib: float = memory_model.DEFAULT_MEMORY_LIMIT_GIB,
        backend: str = "auto",
        integrator: str = "series",
        runtime_bytes: int | None = None,
        plan: PlanOutcome | None = None,
    ) -> Budget:
        """The budget, or ParameterError past ``memory_limit_gib`` (lutbake/grid/memory.py)."""
        return memory_model.check_budget(self, memory_limit_gib, backend, integrator, runtime_bytes, plan)

    def describe(self) -> dict[str, Any]:
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


def _check_spec(spec: BakeSpec) -> None:
    """ValueError (ParameterError where a flag names the value) unless ``spec`` is a spec lutbake bakes: its
    settings among the allowed, its axes in order and valid, their ranges as the spacings and the corner
    zoom need them, and the grid within MAX_CELLS."""
    check_value("eta1", spec.eta1)
    check_value("eta2", spec.eta2)
    _choice("space", spec.space, SPACES)
    _choice("observer", spec.observer, OBSERVERS)
    _choice("precision", spec.precision, PRECISIONS)
    _choice("interpolation", spec.interpolation, INTERPOLATIONS)
    _choice("compute", spec.compute, COMPUTE_PRECISIONS)
    _choice("method", spec.method, METHODS)
    if [a.name for a in spec.axes] != list(AXIS_NAMES):
        raise ValueError(f"axes must be {', '.join(AXIS_NAMES)} in that order")
    for axis in spec.axes:
        validate_axis(axis)
    eta3 = spec.axis["eta3"]
    if eta3.spacing in ADMITTANCE_SPACINGS and eta3.lo < spec.eta1:
        raise ParameterError(
            "{eta3} " + eta3.spacing + " spacing needs A >= eta1 ({eta1}), got {lo}",
            eta1=f"{spec.eta1:g}",
            lo=f"{eta3.lo:g}",
        )
    if eta3.corner and eta3.lo != spec.eta1:
        raise ParameterError(
            "{eta3} corner zoom needs A = eta1 ({eta1}), got {lo}", eta1=f"{spec.eta1:g}", lo=f"{eta3.lo:g}"
        )
    if spec.has_corner and spec.axis["cos_theta"].lo != 0.0:
        raise ParameterError(
            "{cos_theta} range must start at 0 under a corner zoom, got {lo}", lo=f"{spec.axis['cos_theta'].lo:g}"
        )
    if not 1.0 <= spec.samples_per_cycle <= 64.0:
        raise ValueError(f"samples per cycle {spec.samples_per_cycle:g} is outside [1, 64]")
    if spec.cells > MAX_CELLS:
        raise ValueError(f"grid of {spec.cells} cells exceeds the {MAX_CELLS} cell limit: use fewer nodes")


def _choice(name: str, value: str, allowed: Collection[str]) -> None:
    if value not in allowed:
        raise ValueError(f"{name} {value!r} is not one of {', '.join(allowed)}")
