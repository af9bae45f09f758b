"""A bake's budget before any work: its cells, output bytes, peak resident memory and seconds.

The memory model (``MEMORY``) states what a bake holds, in bytes, item by item from the code that
allocates it, with per-item constants fitted to peak RSS measured by bench/bench_memory.py (a process
that bakes one shape; the allocators keep some freed memory, so these are resident bytes, not the
arrays' sizes alone); tests/grid/test_memory.py holds the estimate within 1.25x of measured peaks.
``check_budget`` refuses a grid whose estimate passes the memory limit (`bake --memory-limit-gib`).
BakeSpec's ``memory``, ``budget`` and ``check_budget`` are these functions on the spec.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol, TypedDict

from lutbake.errors import ParameterError
from lutbake.grid.layout import _CHUNK_CELLS
from lutbake.spectral.rules import MAX_WAVENUMBER_NODES

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec

__all__ = [
    "MEMORY",
    "KEPT_TEXEL_BYTES",
    "KEPT_COLOUR_BYTES",
    "DEFAULT_MEMORY_LIMIT_GIB",
    "estimate_memory",
    "budget",
    "check_budget",
]

DEFAULT_MEMORY_LIMIT_GIB = 8.0
# Bake rates measured by bench/bench_b1.py on this project's CI CPU (cells per second).
_CELLS_PER_SECOND = {"opencl": 8.5e5, "numpy": 2.4e4}
SERIES_CHUNK = 1 << 16  # columns (or pairs) integrate._series_chunks builds at once
_MIB = 1 << 20
# The plan's closed-form colours kept for the bake (integrate.series.KeptColours): bytes per texel (a
# closed-form texel's index and RGB, a direct texel's index), and the most they take (past it the bake
# runs the closed form again).
KEPT_TEXEL_BYTES = {"closed": 32, "direct": 8}
KEPT_COLOUR_BYTES = 64 * _MIB


class PlanOutcome(Protocol):
    """What the estimate reads of a bake's plan (integrate.SeriesStats): texels per path and shared terms."""

    @property
    def closed_form_texels(self) -> int: ...
    @property
    def direct_texels(self) -> int: ...
    @property
    def shared_terms(self) -> int: ...


class _Runtime(TypedDict):
    numpy: int
    opencl: dict[str, int]  # per runtime family


class _MemoryModel(TypedDict):
    runtime: _Runtime
    tables: int
    column: int
    pair: int
    build: int
    pair_table: int
    kept_texel: dict[str, int]
    kept_colours: int
    plan_cell: int
    probes: int
    probes_per_um: float
    flight_cell: dict[str, int]  # per integrator
    numpy_cell: int
    numpy_chunk: int
    screen: int


class Budget(TypedDict):
    """A bake's budget (``budget``): cells, output bytes, peak resident bytes, seconds per backend."""

    cells: int
    output_bytes: int
    peak_memory_bytes: float
    seconds_estimate: dict[str, float]


MEMORY: _MemoryModel = {
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
    "kept_texel": KEPT_TEXEL_BYTES,  # the plan's closed-form colours kept for the bake ...
    "kept_colours": KEPT_COLOUR_BYTES,  # ... at most (integrate.series.KeptColours)
    "plan_cell": 12,  # per cell of a band during the plan: the texels left and the series bounds
    "probes": 30 * _MIB,  # the ground truth at the 48 probes (lutbake/spectral/reference.py) ...
    "probes_per_um": 0.52 * _MIB,  # ... and its growth with the thickest film D (finer rules)
    "flight_cell": {"series": 46, "direct": 80},  # per cell of the bands in flight (the one written, the next baking;
    # one where the image is one band): RGB float64 on the host and
    # the device, the lists of texels left (direct: levels), the plan's mask of them (1 B)
    "numpy_cell": 168,  # per cell of a band on the numpy path: the stacks, levels and RGB, two bands
    "numpy_chunk": 330,  # per (cell, node) pair of NumpyBackend's optics chunk (2^19 at most)
    "screen": 750 << 16,  # capped_texels: one chunk of 2^16 texels screened and filtered
}


def estimate_memory(
    spec: BakeSpec,
    backend: str = "opencl",
    integrator: str = "series",
    runtime_bytes: int | None = None,
    plan: PlanOutcome | None = None,
) -> dict[str, float]:
    """Estimated peak resident memory of baking ``spec``, bytes, by item (``MEMORY``): ``peak`` is the
    runtime, what persists through the bake, and the larger of its two phases (the plan with the probes
    beside it and the capped texels' screen; the bands), plus the whole image where the file's tiles
    run in another order (``retile``). Before any work the runtime is MEMORY's and
    the shared table and the closed form's table are bounded from the shape; a bake checks again with
    the runtime's resident bytes measured (``runtime_bytes``) and its plan's outcome (``plan``:
    integrate.SeriesStats). That last estimate is within 1.25x of peak RSS measured over several
    shapes (tests/grid/test_memory.py)."""
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    band = min(spec.cells, max(_CHUNK_CELLS, spec.image_size[0]))  # row_chunks: at least one image row
    exr = band * 9 * (2 if spec.precision == "half" else 4)  # stored, its planes and their bytes
    probes = MEMORY["probes"] + MEMORY["probes_per_um"] * spec.axis["opd_nm"].hi / 1000.0
    before_work = MEMORY["runtime"]["numpy"] if backend == "numpy" else max(MEMORY["runtime"]["opencl"].values())
    items: dict[str, float] = {"runtime": runtime_bytes or before_work}
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
        items["kept_colours"] = min(MEMORY["kept_colours"], _kept_bytes(spec, plan)) if integrator == "series" else 0
        planning = min(columns, SERIES_CHUNK) * MEMORY["build"] + band * MEMORY["plan_cell"] + probes
        if integrator == "direct":
            planning += MEMORY["screen"]
        in_flight = min(spec.cells, 2 * band)  # bake.write_lut: band k written while band k + 1 bakes
        items["phases"] = max(planning, in_flight * MEMORY["flight_cell"][integrator] + exr)
    if spec.file_layout != spec.layout:  # bake.write_lut re-tiles the whole image, as stored, in 3 copies
        items["retile"] = spec.cells * 9 * (2 if spec.precision == "half" else 4)
    items["peak"] = sum(items.values())
    return items


def _kept_bytes(spec: BakeSpec, plan: PlanOutcome | None) -> int:
    """Bytes the plan's kept colours would take (before the plan: every texel by the closed form)."""
    kept = MEMORY["kept_texel"]
    if plan is None:
        return spec.cells * kept["closed"]
    return plan.closed_form_texels * kept["closed"] + plan.direct_texels * kept["direct"]


def budget(
    spec: BakeSpec,
    backend: str = "auto",
    integrator: str = "series",
    runtime_bytes: int | None = None,
    plan: PlanOutcome | None = None,
) -> Budget:
    """Cells, output bytes, estimated peak memory (``estimate_memory``) and bake seconds (per backend) of
    baking ``spec``, before any work. ``backend`` 'auto' takes the larger of the two paths' peaks (it may
    fall back to numpy)."""
    names = ("opencl", "numpy") if backend == "auto" else (backend,)
    peak = max(estimate_memory(spec, name, integrator, runtime_bytes, plan)["peak"] for name in names)
    return {
        "cells": spec.cells,
        "output_bytes": spec.cells * 3 * (2 if spec.precision == "half" else 4),
        "peak_memory_bytes": peak,
        "seconds_estimate": {name: spec.cells / rate for name, rate in _CELLS_PER_SECOND.items()},
    }


def check_budget(
    spec: BakeSpec,
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    backend: str = "auto",
    integrator: str = "series",
    runtime_bytes: int | None = None,
    plan: PlanOutcome | None = None,
) -> Budget:
    """``spec``'s budget, or ParameterError when ``memory_limit_gib`` is not a finite number > 0 or the
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
    b = budget(spec, backend, integrator, runtime_bytes, plan)
    if b["peak_memory_bytes"] > limit * (1 << 30):
        raise ParameterError(
            "grid {grid} needs about {need} GiB of memory, over the {limit} GiB limit: use "
            "fewer nodes or raise {memory_limit_gib}",
            grid=" x ".join(map(str, spec.shape)),
            need=f"{b['peak_memory_bytes'] / (1 << 30):.1f}",
            limit=f"{limit:g}",
        )
    return b
