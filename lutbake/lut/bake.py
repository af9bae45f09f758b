"""Bake: run a plan through an integrator and stream it into a LUT file set.

Outputs beside each other: NAME.exr (authoritative, self-describing),
NAME.json (the same metadata), NAME.glsl and NAME.hlsl (samplers), committed
as one set (lutbake/io/fileset.py).

Before baking, the spectral rule's error is measured against the ground
truth (lutbake/spectral/reference.py) at probe cells spread over the grid, including the
thickest film and grazing incidence, and recorded as
``spectral.error_rgb_max``: the figure the kernel's direct path is held to.
The kernel integrates most texels by the Fourier series instead
(lutbake/spectral/fourier.py); ``integrator`` records its rule, how many texels took
it and the largest a-priori bound it enforced.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lutbake import __version__
from lutbake.errors import ParameterError
from lutbake.grid.memory import DEFAULT_MEMORY_LIMIT_GIB
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.bands import bake_rows_all
from lutbake.integrate.numpy_path import NumpyBackend
from lutbake.integrate.opencl import backend as make_backend
from lutbake.io.fileset import FileSet, open_set
from lutbake.lut.pipeline import BakeStages, OnBand, stream_bands
from lutbake.physics.points import FilmPoints
from lutbake.spectral.fourier import DEFAULT_SERIES_TOLERANCE, SERIES_BUDGET, series_colour, weight_transform
from lutbake.spectral.reference import reference_colour
from lutbake.spectral.rules import STENCIL_NODES
from lutbake.tables.exr import exr_rows
from lutbake.tables.headers import FORMAT
from lutbake.tables.lutfile import write_companions

if TYPE_CHECKING:
    from lutbake.integrate.devices import DeviceChoice

# what bake_set bakes: (the EXR to write, its spec, {"on_band": ..., "chunk_cells": ...})
BakeJob = tuple[Path | str, BakeSpec, dict]

__all__ = [
    "BakeResult",
    "bake",
    "bake_set",
    "write_lut",
    "lut_members",
    "bake_array",
    "default_specs",
    "metadata",
    "spectral_error",
]

_PROBES = 48


@dataclass
class BakeResult:
    """What a bake wrote and what it cost.

    Attributes
    ----------
    path : pathlib.Path
        The EXR written (its .json sidecar and .glsl/.hlsl includes lie beside it).
    cells : int
        Texels integrated.
    seconds : float
        Wall time of the integration, s (``cells_per_second`` divides).
    backend, device : str
        'opencl' or 'numpy', and the device that ran (runtime / device name).
    spectral_error_rgb_max : float
        Largest |ΔRGB| of the bake's integrator against the ground truth at probe texels.
    capped_texels, truncation_bound, capped_error_rgb_max
        Texels whose spectral rule hit its node cap, the bound on their truncation error, and their
        measured error (0 when none).
    stages : BakeStages
        Where ``seconds`` went (the integrator's start, the plan, the device, the write) and the CPU time
        over them (lutbake/lut/pipeline.py).

    Examples
    --------
    A shipped spec at 4 nodes per axis (``Axis.resized`` keeps a corner zoom's share of the nodes):

    >>> from dataclasses import replace
    >>> import lutbake
    >>> spec = lutbake.default_specs()["lutbake-eta2-1.50"]
    >>> small = replace(spec, axes=tuple(axis.resized(4) for axis in spec.axes))
    >>> result = lutbake.bake_lut(small, "small.exr")
    >>> result.cells, result.path.name, bool(result.spectral_error_rgb_max < 1e-6)
    (256, 'small.exr', True)
    """

    path: Path
    cells: int
    seconds: float
    backend: str
    device: str
    spectral_error_rgb_max: float
    capped_texels: int = 0
    truncation_bound: float = 0.0
    capped_error_rgb_max: float = 0.0
    stages: BakeStages = field(default_factory=BakeStages)

    @property
    def cells_per_second(self) -> float:
        return self.cells / max(self.seconds, 1e-12)


def default_specs(precision: str = "half") -> dict:
    """The embedded default LUT set: soap/water-like, glass-like and oxide-like films, each in two LUTs
    by the base it sits on: dielectric (and weakly absorbing) bases, and metals.

    Parameters
    ----------
    precision : str
        Storage of the EXR: 'half' (16-bit float, the engines' choice) or 'float'.

    Returns
    -------
    dict
        LUT name → BakeSpec, in the order `lutbake bake` writes them.

    Domains (docs/accuracy.md): ``lutbake-eta2-X`` covers η3 1–3, κ3 0–2 (glass, water, oxides,
    weak absorbers); ``lutbake-eta2-X-metal`` covers η3 0.02–4, κ3 1.5–9, where Au, Ag, Cu, Al, Fe,
    Ti and Cr fall over 400–700 nm. Splitting the base there lets each grid follow its own hard
    corner; both are read cubic (clamped). Metals: cos θ, D and η3 in √, κ3 in ¼ power (the low-loss
    corner near grazing, where the film's resonances are sharpest). Dielectric: the grazing corner
    cos θ1, D, η3 − η1, κ3 → 0, where the colour is a function of ratios to cos θ1 only, is zoomed into
    (format v5, docs/lut-format.md#the-grazing-corner): D, η3 and κ3 mix their own spacings (√,
    sqrt-admittance, √) with those ratios, and cos θ1 is uniform in (cos θ1 + cos θ1^¼)/2. Counts from
    the searched maximum and the p99 at 5,000 held-out points against the ground truth
    (docs/accuracy.md), under 8 MiB of EXR per LUT in half precision and 4096 texels a side (η2 2.0's
    metal LUT, 200 D × 30 κ3 nodes, lays its tiles along x by κ3: format v6).

    Examples
    --------
    >>> import lutbake
    >>> specs = lutbake.default_specs()
    >>> list(specs)[:2], specs["lutbake-eta2-1.33"].shape, specs["lutbake-eta2-1.33-metal"].axes[2].lo
    (['lutbake-eta2-1.33', 'lutbake-eta2-1.33-metal'], (46, 104, 24, 24), 0.02)
    """
    specs = {}
    for eta2 in _DIELECTRIC_COUNTS:
        specs[f"lutbake-eta2-{eta2:.2f}"] = BakeSpec(
            eta2=eta2, axes=_dielectric_axes(*_DIELECTRIC_COUNTS[eta2]), precision=precision
        )
        specs[f"lutbake-eta2-{eta2:.2f}-metal"] = BakeSpec(
            eta2=eta2, axes=_metal_axes(*_METAL_COUNTS[eta2]), precision=precision
        )
    return specs


# Node counts per film, cos θ × D × η3 × κ3: thinner films (η2 1.33) need more cos θ nodes at normal
# incidence, where a thick film's phase turns with cos θ1 as 1/η2²; η2 2.0 over metals needs D and κ3
# at the low-loss corner near grazing (docs/accuracy.md).
_DIELECTRIC_COUNTS = {1.33: (46, 104, 24, 24), 1.5: (36, 120, 24, 24), 2.0: (36, 120, 24, 24)}
_METAL_COUNTS = {1.33: (40, 146, 16, 28), 1.5: (36, 160, 16, 25), 2.0: (30, 200, 18, 30)}
# The dielectric LUTs' grazing corner zoom (docs/lut-format.md#the-grazing-corner): nodes and scale per
# axis. Their ratio parts resolve the corner's colour, whose darkest valleys (a thin film's and a weak
# absorber's reflections cancelling) set the counts; κ3's zoom also serves weak absorbers at any angle,
# so its own spacing is √ rather than ¼ power (docs/accuracy.md).
_CORNER = {"opd_nm": (24, 100.0), "eta3": (8, 1.0), "kappa3": (14, 0.3)}


def _dielectric_axes(n_cos: int, n_opd: int, n_eta3: int, n_kappa3: int) -> tuple[Axis, Axis, Axis, Axis]:
    return (
        Axis("cos_theta", 0.0, 1.0, n_cos, "uniform-root4"),
        Axis("opd_nm", 0.0, 3000.0, n_opd, "sqrt", _CORNER["opd_nm"]),
        Axis("eta3", 1.0, 3.0, n_eta3, "sqrt-admittance", _CORNER["eta3"]),
        Axis("kappa3", 0.0, 2.0, n_kappa3, "sqrt", _CORNER["kappa3"]),
    )


def _metal_axes(n_cos: int, n_opd: int, n_eta3: int, n_kappa3: int) -> tuple[Axis, Axis, Axis, Axis]:
    return (
        Axis("cos_theta", 0.0, 1.0, n_cos, "sqrt"),
        Axis("opd_nm", 0.0, 3000.0, n_opd, "sqrt"),
        Axis("eta3", 0.02, 4.0, n_eta3, "sqrt"),
        Axis("kappa3", 1.5, 9.0, n_kappa3, "root4"),
    )


def _probe_points(spec: BakeSpec) -> FilmPoints:
    """Deterministic probe cells: random nodes plus the thickest film at grazing-ish angles."""
    rng = np.random.default_rng(int(spec.content_hash[:8], 16))
    idx = [rng.integers(0, n, _PROBES) for n in spec.shape]
    idx[1][: _PROBES // 4] = spec.shape[1] - 1
    return spec.texel_stacks([a.values()[i] for a, i in zip(spec.axes, idx)])


def _error_at(spec: BakeSpec, stack: FilmPoints) -> float:
    """max |ΔRGB| of the bake's spectral rules against the ground truth at texels."""
    if len(stack) == 0:
        return 0.0
    fast = NumpyBackend().evaluate(spec, stack)
    truth = reference_colour(stack, spec.observer, spec.space).values
    return float(np.max(np.abs(fast - truth)))


def spectral_error(spec: BakeSpec) -> float:
    """max |ΔRGB| of the bake's spectral rules against the ground truth at the probe cells."""
    return _error_at(spec, _probe_points(spec))


def capped_error(spec: BakeSpec, direct_texels: int | None = None) -> tuple[int, float, float]:
    """(texels past the node cap among those the direct quadrature integrates, their a-priori bound, the
    error measured at the worst 64).

    ``direct_texels``: how many texels the integrator leaves to the direct quadrature (its plan); None
    when it integrates every texel so (the numpy path, ``integrator='direct'``). Where the series or the
    poles' closed form take the rest, the capped texels among them are found by the same rule in numpy
    (lutbake.spectral.fourier.series_colour) and only those on the direct path are counted and measured."""
    if direct_texels == 0:
        return 0, 0.0, 0.0

    def direct(
        texels: Sequence[np.ndarray],
    ) -> np.ndarray:  # float32 kernels have no closed form: what the series leaves is direct there
        path = series_colour(spec.texel_stacks(texels), spec.observer, spec.space, integrate=False).path
        return path == 2 if spec.compute == "float64" else path > 0

    count, bound, texels = spec.capped_texels(keep=None if direct_texels is None else direct)
    return count, bound, _error_at(spec, spec.texel_stacks(texels))


def integrator_metadata(spec: BakeSpec, series: dict) -> dict:
    """The per-texel choice of integrator: the rules of the series and of the poles' closed form, and
    their outcome over the grid."""
    from lutbake.spectral import poles

    wt = weight_transform(spec.observer, spec.space)
    return {
        "rule": "fourier-series where in scope and within budget, else the poles' closed form where the film "
        "propagates and its bound is within the tolerance, else the direct spectral rule",
        "series_tolerance_per_polarization": DEFAULT_SERIES_TOLERANCE,
        "series_budget_terms": SERIES_BUDGET,
        "table_step_nm": wt.step_nm,
        "table_max_nm": wt.x_max_nm,
        "table_interpolation_bound": float(wt.interpolation_bound.max()),
        "closed_form": {
            "near_ellipse_rho": poles.NEAR_RHO,
            "bound_ellipse_rho": poles.BOUND_RHO,
            "chebyshev_degree": poles.CHEBYSHEV_DEGREE,
            "max_near_poles": poles.MAX_NEAR_POLES,
            "cauchy_table_bound": float(poles.cauchy_table(spec.observer, spec.space).bound.max()),
        },
        **series,
    }


def _format_version(spec: BakeSpec) -> int:
    """The lowest version whose readers know all the file uses: 6 for tiles laid along x by κ3, 5 for the
    corner zoom or the uniform-root4 spacing, else 4 (such LUTs stay byte for byte as v4 readers know them)."""
    if spec.file_layout.tiles_x != "eta3":
        return 6
    if spec.has_corner or any(a.spacing == "uniform-root4" for a in spec.axes):
        return 5
    return 4


def metadata(
    spec: BakeSpec, error_rgb_max: float, capped: tuple[int, float, float] = (0, 0.0, 0.0), series: dict | None = None
) -> dict:
    illuminant = "D65" if spec.space != "acescg" else "ACES white (CIE daylight series)"
    return {
        "format": FORMAT,
        "format_version": _format_version(spec),
        "lutbake_version": __version__,
        "content_hash": spec.content_hash,
        "axes": [a.describe() for a in spec.axes],
        "packing": spec.file_layout.packing(),
        "constants": {"eta1": spec.eta1, "eta2": spec.eta2},
        "observer": spec.observer,
        "illuminant": illuminant,
        "space": spec.space,
        "encoding": "linear",
        "method": spec.method,
        "spectral": {
            "rule": f"wavenumber-lagrange{STENCIL_NODES}-product",
            "counts": spec.ladder.counts,
            "range_nm": [360.0, 830.0],
            "samples_per_cycle": spec.samples_per_cycle,
            "error_rgb_max": error_rgb_max,
            "error_probes": _PROBES,
            "capped_texels": capped[0],
            "truncation_bound_rgb": capped[1],
            "capped_error_rgb_max": capped[2],
        },
        "precision": spec.precision,
        "interpolation": spec.interpolation,
        "compute": spec.compute,
        "channels": ["R", "G", "B"],
    } | ({"integrator": integrator_metadata(spec, series)} if series is not None else {})


def bake(
    spec: BakeSpec,
    out_path: str | PathLike[str],
    backend: str = "auto",
    on_band: OnBand | None = None,
    chunk_cells: int | None = None,
    integrator: str = "series",
    device: DeviceChoice = None,
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    exr_threads: int | None = None,
) -> BakeResult:
    """Bake ``spec`` into ``out_path`` (an .exr) plus sidecar and shader includes, as one set.

    The set (NAME.exr, NAME.json, NAME.glsl, NAME.hlsl) is committed as a unit: an interrupted or
    failed bake leaves the previous set. The EXR's bytes do not depend on the device; the sidecar
    records it under ``baked_on``.

    Parameters
    ----------
    spec : BakeSpec
        Film, axes, precision and spectral settings.
    out_path : str or os.PathLike
        The EXR to write; its folder must exist.
    backend : str
        'auto' (OpenCL, else numpy with a warning), 'opencl' or 'numpy'.
    on_band : callable, optional
        ``on_band(rows_done, rows_total)`` after each band of image rows (and with 0 rows first, before
        the spectral rule's error is measured).
    chunk_cells : int, optional
        Texels per kernel launch (memory bound); default from the plan.
    integrator : str
        Kernel path: 'series' (the exact Fourier series, direct quadrature where out of scope) or
        'direct' (quadrature for every texel).
    device : str, optional
        OpenCL device: index, key ('pocl-system', 'pocl-pypi', 'intel-pypi'), runtime ('pocl': the first PoCL
        that builds the kernel) or part of its label (lutbake/integrate/devices.py).
    memory_limit_gib : float
        Refuse specs whose image and work buffers would exceed this, GiB.
    exr_threads : int, optional
        Threads of OpenEXR's compression pool (None: the cores this process may run on; 0: the writing
        thread alone). The bytes do not depend on it (lutbake/tables/exr.py).

    Returns
    -------
    BakeResult

    Examples
    --------
    >>> import lutbake
    >>> axes = (lutbake.Axis("cos_theta", 0.0, 1.0, 8, "sqrt"), lutbake.Axis("opd_nm", 0.0, 2000.0, 32),
    ...         lutbake.Axis("eta3", 1.0, 3.0, 4), lutbake.Axis("kappa3", 0.0, 5.0, 4, "sqrt"))
    >>> result = lutbake.bake_lut(lutbake.BakeSpec(eta2=2.0, axes=axes), "oxide.exr")
    >>> sorted(p.name for p in result.path.parent.glob("oxide.*"))
    ['oxide.exr', 'oxide.glsl', 'oxide.hlsl', 'oxide.json']
    """
    out_path = Path(out_path)
    job = (out_path, spec, {"on_band": on_band, "chunk_cells": chunk_cells})
    return bake_set([job], out_path.name, backend, memory_limit_gib, integrator, device, exr_threads)[0]


def bake_set(
    jobs: Sequence[BakeJob],
    set_name: str,
    backend: str = "auto",
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    integrator: str = "series",
    device: DeviceChoice = None,
    exr_threads: int | None = None,
) -> list[BakeResult]:
    """Bake several LUTs into one folder as one file set (the default set): every LUT's files are
    committed together or, when any bake fails or is interrupted, none is (lutbake/io/fileset.py).

    Parameters
    ----------
    jobs : list of (out_path, BakeSpec, dict)
        The EXR to write, its spec, and ``on_band``/``chunk_cells`` for it (see ``bake``); one folder.
    set_name : str
        The set's name in its commit journal (``.SET_NAME.commit``).
    backend, memory_limit_gib, integrator, device, exr_threads
        As for ``bake``; every spec's budget and output path are checked before any work.

    Returns
    -------
    list of BakeResult
        In the order of ``jobs``.
    """
    folders = {Path(path).parent for path, _, _ in jobs}
    if len(folders) != 1:
        raise ValueError(f"a file set lives in one folder; these LUTs go to {len(folders)}")
    for path, spec, _ in jobs:
        spec.check_budget(memory_limit_gib, backend, integrator)
        _check_writable(Path(path))
    with open_set(folders.pop(), set_name) as files:
        return [
            write_lut(
                spec,
                Path(path),
                files,
                backend,
                integrator=integrator,
                device=device,
                memory_limit_gib=memory_limit_gib,
                exr_threads=exr_threads,
                **options,
            )
            for path, spec, options in jobs
        ]


def write_lut(
    spec: BakeSpec,
    out_path: Path,
    files: FileSet,
    backend: str = "auto",
    on_band: OnBand | None = None,
    chunk_cells: int | None = None,
    integrator: str = "series",
    device: DeviceChoice = None,
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    exr_threads: int | None = None,
) -> BakeResult:
    """Bake ``spec`` into temporaries of ``files`` (committed by the caller). Once the integrator is up,
    the memory budget is checked again with the runtime's resident memory as measured."""
    start, cpu_start, stages = time.perf_counter(), time.process_time(), BakeStages()
    if on_band:
        on_band(0, spec.image_size[1])
    with stages.clock("compile"):
        fast = make_backend(backend, spec.compute, integrator, device)
    runtime = resident_bytes()
    spec.check_budget(memory_limit_gib, fast.name, integrator, runtime)
    with stages.clock("plan"), ThreadPoolExecutor(1) as host:  # the probes' ground truth (numpy) while the device plans
        probes = host.submit(spectral_error, spec)
        plan = fast.series_plan(spec)
        error = probes.result()
        spec.check_budget(memory_limit_gib, fast.name, integrator, runtime, plan)
        capped = capped_error(spec, None if plan.direct_texels == spec.cells else plan.direct_texels)
    meta = metadata(spec, error, capped, plan.describe())
    sidecar = {**meta, "baked_on": {"backend": fast.name, "device": fast.device}}
    chunks = spec.row_chunks(chunk_cells) if chunk_cells else spec.row_chunks()
    with exr_rows(files.temp(out_path), *spec.file_layout.size, meta, spec.precision, threads=exr_threads) as exr:
        stream_bands(fast, spec, exr, chunks, stages, on_band)
    with stages.clock("write"):
        write_companions(files, out_path, meta, sidecar)
    stages.cpu_s = time.process_time() - cpu_start
    seconds = time.perf_counter() - start
    return BakeResult(out_path, spec.cells, seconds, fast.name, fast.device, error, *capped, stages=stages)


def resident_bytes(peak: bool = False) -> int:
    """The process's resident memory now (or its peak so far), bytes: Linux's VmRSS (VmHWM) in
    /proc/self/status; elsewhere getrusage's peak. (getrusage's peak is not this process's alone: a
    process forked from a larger one reports the parent's resident size until it outgrows it.)"""
    import resource

    field = "VmHWM:" if peak else "VmRSS:"
    try:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) * 1024 for line in status if line.startswith(field))
    except (OSError, ValueError, IndexError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def lut_members(out_path: Path) -> list[Path]:
    """The files of a LUT set."""
    return [out_path.with_suffix(f".{s}") for s in ("exr", "json", "glsl", "hlsl")]


def bake_array(
    spec: BakeSpec, backend: str = "auto", integrator: str = "series", device: DeviceChoice = None
) -> np.ndarray:
    """The whole image (height, width, 3) in float64, packed as the file is, in memory (tests, benchmarks)."""
    return spec.file_layout.retile(
        bake_rows_all(make_backend(backend, spec.compute, integrator, device), spec), spec.layout
    )


def _check_writable(out_path: Path) -> None:
    import os

    if out_path.suffix.lower() != ".exr":
        raise ParameterError("{out_path} {path} must end in .exr", path=repr(str(out_path)))
    folder = out_path.parent
    if not folder.is_dir():
        raise ParameterError("{out_path} folder {path} does not exist", path=repr(str(folder)))
    if not os.access(folder, os.W_OK):
        raise ParameterError("{out_path} folder {path} is not writable", path=repr(str(folder)))
    for member in lut_members(out_path):
        if member.is_dir():
            raise ParameterError(
                "{out_path} {path}: {member} is a folder, expected a file or nothing",
                path=repr(str(out_path)),
                member=repr(str(member)),
            )
