"""Integrate a bake plan to RGB, band by band: the OpenCL kernel or the numpy path.

Both return the RGB of every texel of a band of image rows, an array
(rows, width, 3):

* ``OpenCLBackend`` runs kernels/airy.cl through pyopencl, by default on
  the first device in lutbake/integrate/devices.py's order (PoCL, the system's before
  PyPI's, then Intel's CPU runtime) that builds the kernel and passes its
  self-check; ``--device`` or ``PYOPENCL_CTX`` picks any other (a GPU's
  driver runs the same source unchanged). The program is built
  once per process and compute precision. By default each texel is summed
  as the exact Fourier series (lutbake/spectral/fourier.py) where its rule allows,
  and integrated by the spectral rule elsewhere.
* ``NumpyBackend`` evaluates optics.film_reflectance (the ground truth's
  float64 physics) at the rule's nodes: the reference for the kernel in
  tests, and the fallback where no OpenCL platform exists.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import os
import warnings
from importlib import resources

import numpy as np

from lutbake.errors import OpenCLUnavailable, ParameterError
from lutbake.grid.memory import SERIES_CHUNK
from lutbake.integrate.devices import (
    _every_runtime_registered,
    _opencl,
    device_key,
    device_label,
    find_device,
    find_devices,
    opencl_devices,
    runtime_of,
)
from lutbake.physics.optics import film_reflectance, normal_admittance
from lutbake.physics.points import FilmPoints
from lutbake.spectral.fourier import (
    DEFAULT_SERIES_TOLERANCE,
    NU0_PER_NM,
    SERIES_BUDGET,
    series_coefficients,
    series_colour,
    weight_transform,
)
from lutbake.spectral.reference import subset

__all__ = [
    "NumpyBackend",
    "OpenCLBackend",
    "backend",
    "OpenCLUnavailable",
    "DeviceCannotRun",
    "opencl_devices",
    "find_device",
    "device_key",
    "device_label",
    "self_check_error",
]


class NumpyBackend:
    """float64 numpy evaluation of the exact Airy reflectance at each texel's rule nodes."""

    name = "numpy"
    device = "numpy / float64 (host CPU)"
    _CELLS_X_NODES = 1 << 19  # (cell, node) pairs per optics call: ~310 bytes each (plan.MEMORY)

    def bake_rows(self, spec, y0, y1):
        stacks = spec.texel_stacks(a.ravel() for a in spec.cell_params(y0, y1))
        return with_grazing_white(spec, y0, self.evaluate(spec, stacks).reshape(y1 - y0, -1, 3))

    def begin_rows(self, spec, y0, y1) -> "PendingRows":
        return PendingRows(self.bake_rows(spec, y0, y1))

    @staticmethod
    def series_plan(spec) -> "SeriesStats":
        """This path integrates every texel directly."""
        return SeriesStats((0, 0, spec.cells))

    def evaluate(self, spec, stack: FilmPoints):
        """RGB (P, 3) of P stacks of the spec's film (flat fields), each at its texel's rule nodes."""
        levels = _levels(spec, stack)
        out = np.empty((levels.size, 3))
        for level in np.unique(levels):
            rule = spec.ladder.rule(level)
            cells = np.flatnonzero(levels == level)
            step = max(1, self._CELLS_X_NODES // rule.count)
            for s in range(0, cells.size, step):
                i = cells[s : s + step]
                refl = film_reflectance(subset(stack, i).as_column(), rule.wavelength_nm)[2]
                out[i] = refl @ rule.weights.T
        return out


def _levels(spec, stack: FilmPoints) -> np.ndarray:
    """Each stack's spectral rule level, once the stack is known to be of the spec's film."""
    stack.require("spec", film=None, base=None, eta1=spec.eta1, eta2=spec.eta2)
    return spec.cell_levels(stack.cos_theta, stack.opd_nm, stack.eta3, stack.kappa3)


def _signed_cos_theta2(eta1, eta2, cos_theta):
    """|cos θ2| of the film, negated where the film is evanescent (the kernel's convention)."""
    g2 = normal_admittance(eta2, 0.0, eta1, cos_theta)  # exactly as the numpy path
    return np.where(g2.imag > 0, -g2.imag, g2.real) / eta2


def _split(values, dtype):
    """(hi, lo) with hi + lo ≈ values to twice the precision of ``dtype``."""
    values = np.asarray(values, np.float64)
    hi = values.astype(dtype)
    lo = (values - hi.astype(np.float64)).astype(dtype)
    return np.ascontiguousarray(hi), np.ascontiguousarray(lo)


def _candidate_devices(selector=None):
    """Devices to try, in order: those ``selector`` (or $LUTBAKE_DEVICE) names, else the one
    PYOPENCL_CTX names, else every device (``opencl_devices`` order)."""
    cl = _opencl()

    selector = selector or os.environ.get("LUTBAKE_DEVICE")
    if selector:
        return find_devices(selector)
    if os.environ.get("PYOPENCL_CTX"):
        try:
            with _every_runtime_registered():
                return [cl.create_some_context(interactive=False).devices[0]]
        except (cl.Error, RuntimeError, ValueError) as exc:  # pyopencl's words for a selector it cannot match
            raise ValueError(
                f"PYOPENCL_CTX={os.environ['PYOPENCL_CTX']!r} names no OpenCL device ({exc}): "
                "unset it, or give a platform:device index such as 0:0"
            ) from None
    return opencl_devices()


KERNEL_SOURCES = ("kernels/airy.cl", "kernels/poles.cl")


def _kernel_defines() -> list:
    """The closed form's geometry (lutbake/spectral/poles.py) as build options: one statement of each constant."""
    from lutbake.spectral import poles

    real = {
        "BAND_CENTRE": poles.BAND_CENTRE_NM,
        "BAND_HALF": poles.BAND_HALF_NM,
        "NEAR_RHO": poles.NEAR_RHO,
        "BOUND_RHO": poles.BOUND_RHO,
        "WINDOW_LO": poles.WINDOW_NU_PER_NM[0],
        "WINDOW_HI": poles.WINDOW_NU_PER_NM[1],
        "CAUCHY_SHALLOW": poles.SHALLOW_NM,
    }
    whole = {
        "MAX_NEAR": poles.MAX_NEAR_POLES,
        "MAX_WINDOW": poles.MAX_WINDOW,
        "CAUCHY_RE_MIN": int(poles.RE_MIN_NM),
        "CAUCHY_RE_MAX": int(poles.RE_MAX_NM),
        "CAUCHY_NEAR_KNOTS": poles.NEAR_KNOTS,
        "SHALLOW_DEGREE": poles.SHALLOW_DEGREE,
        "DEEP_DEGREE": poles.DEEP_DEGREE,
        "DEEP_LEVELS": poles.DEEP_LEVELS,
        "KNOT_MIN": int(poles.WAVELENGTH_MIN_NM),
        "N_KNOTS": poles.N_KNOTS,
        "CHEB_NODES": poles.CHEBYSHEV_DEGREE + 1,
    }
    return [f"-D{name}=((REAL){value!r})" for name, value in real.items()] + [
        f"-D{name}={value}" for name, value in whole.items()
    ]


def _build(device, compute: str):
    cl = _opencl()

    if compute == "float64" and "cl_khr_fp64" not in device.extensions:
        raise OpenCLUnavailable(f"device {device.name.strip()!r} has no float64: bake with compute float32")
    ctx = cl.Context([device])
    source = "\n".join(resources.files("lutbake.integrate").joinpath(name).read_text() for name in KERNEL_SOURCES)
    options = (["-DLUTBAKE_FP64"] if compute == "float64" else []) + _kernel_defines()
    # pyopencl caches binaries in $XDG_CACHE_HOME; where that fails (a file there, a read-only folder) it
    # reads PYOPENCL_CACHE_FAILURE_FATAL with os.environ[...] and raises KeyError when it is unset. Empty
    # means "not fatal": it warns (silenced here) and builds without the cache.
    with warnings.catch_warnings(), _environment(PYOPENCL_CACHE_FAILURE_FATAL=""):
        warnings.simplefilter("ignore")
        return ctx, cl.Program(ctx, source).build(options=options)


@contextlib.contextmanager
def _environment(**defaults):
    """Environment variables set to ``defaults`` where unset, for the block only."""
    added = [name for name in defaults if name not in os.environ]
    os.environ.update({name: defaults[name] for name in added})
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


# Self-check stacks: stiff corners where runtimes have disagreed (grazing incidence over a
# base matching the ambient, thick films, metals, evanescent films), R compared with numpy.
_SELF_CHECK = np.array(
    [
        # cos θ1, D (nm), η3, κ3, λ (nm)
        [1e-6, 0.0, 1.0, 1e-12, 550.0],
        [1e-6, 1e-9, 1.0, 1e-12, 400.0],
        [0.0, 500.0, 1.5, 0.0, 500.0],
        [0.3, 1e5, 2.0, 3.0, 700.0],
        [1.0, 800.0, 1.0, 0.0, 450.0],
        [0.05, 4000.0, 0.2, 3.5, 610.0],
        [0.7, 250.0, 1.5, 1e-9, 380.0],
        [1e-12, 1e4, 3.0, 100.0, 820.0],
    ]
)
SELF_CHECK_TOLERANCE = {"float64": 1e-10, "float32": 2e-5}
# Nodes per work-item of stack_rgb: its few stiff points on the finest rules still spread over every core.
_STACK_BLOCK = 256
# One work-group size for every launch (global sizes padded to it; the kernels return past their count):
# PoCL builds a kernel's work-group function per distinct local size, which it picks per global size when
# left to choose — ~0.2 s each, and a scene's trials and levels meet dozens of sizes.
_LOCAL_SIZE = 64
_STACK_TERMS = 18  # reals per (cos θ1, node) in stack_terms' output (STACK_TERMS in airy.cl)


_SELF_CHECKED = {}


def _self_check(backend, device) -> float:
    """``self_check_error`` once per device, compute precision and integrator per process."""
    key = (device.int_ptr, backend.compute, backend.integrator)
    if key not in _SELF_CHECKED:
        _SELF_CHECKED[key] = self_check_error(backend)
    return _SELF_CHECKED[key]


def self_check_error(backend) -> float:
    """Largest error of the kernel against numpy: R at the self-check stacks (films η2 1.5 under
    η1 1 and η2 1.2 under η1 1.6), and the baked RGB of a small grid through the backend's
    integrator (series or direct) against the numpy path's direct quadrature."""
    from lutbake.grid.spec import Axis, BakeSpec

    cos1, opd, eta3, kappa3, lam = _SELF_CHECK.T
    worst = 0.0
    for eta1, eta2 in ((1.0, 1.5), (1.6, 1.2)):
        stack = FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos1, opd_nm=opd, eta3=eta3, kappa3=kappa3)
        fast = backend.reflectance(stack, lam)
        ref = film_reflectance(stack, lam)[2]
        worst = max(worst, float(np.max(np.abs(fast - ref))))
    grid = BakeSpec(
        eta2=1.5,
        compute=backend.compute,
        axes=(
            Axis("cos_theta", 0.0, 1.0, 4),
            Axis("opd_nm", 0.0, 2000.0, 4),
            Axis("eta3", 1.0, 3.0, 2),
            Axis("kappa3", 0.0, 4.0, 2),
        ),
    )
    expected = bake_rows_all(NumpyBackend(), grid)
    if getattr(backend, "integrator", "direct") == "series":
        stacks = grid.texel_stacks(np.ravel(p) for p in grid.cell_params(0, grid.image_size[1]))
        series = series_colour(stacks, grid.observer, grid.space).values
        expected = np.where(np.isnan(series), expected.reshape(-1, 3), series).reshape(expected.shape)
    return max(worst, float(np.max(np.abs(bake_rows_all(backend, grid) - expected))))


@functools.lru_cache(maxsize=16)
def _program(device, compute: str):
    """(context, program) built for one device, or the OpenCLUnavailable saying why not."""
    cl = _opencl()

    try:
        return _build(device, compute)
    except (cl.Error, OpenCLUnavailable) as exc:
        return OpenCLUnavailable(f"{device_label(device)}: {_why_not_built(device, exc)}")


def _why_not_built(device, exc) -> str:
    """One line: the build log's first error, and where the runtime's LLVM cannot name this CPU (PoCL 3.0
    from PyPI, LLVM 14, on AMD Zen 5: "unknown target CPU 'generic'"), what builds instead."""
    lines = [line.strip() for line in str(exc).strip().splitlines()] or ["build failed"]
    first = next((line for line in lines if "error" in line), lines[0])
    if "unknown target CPU" not in first:
        return first
    return (
        f"cannot compile for this CPU: {first.removeprefix('error: ')} (LLVM {runtime_of(device).llvm or '?'} "
        "does not know this CPU; Debian's pocl-opencl-icd, which picks the target from the CPU's features, "
        "builds on such CPUs)"
    )


KERNELS = {
    "direct_kernel": "bake_texels_direct",
    "series_kernel": "bake_rows_series",
    "series_table_kernel": "bake_rows_series_table",
    "closed_kernel": "bake_texels_closed",
    "pair_kernel": "pair_transform",
    "plan_kernel": "plan_rows",
    "plan_closed_kernel": "plan_texels_closed",
    "max_kernel": "max_chunks",
    "points_kernel": "reflectance_points",
    "stack_terms_kernel": "stack_terms",
    "stack_kernel": "stack_rgb",
}


_DEVICE_STATE = {}


def _device_kernels(device, compute: str):
    """(context, queue, kernels by name, table buffers by key) of one device's program (``_program``),
    made once per program: every backend on it shares them (the default set's six bakes upload the
    colour-weight tables once), or the OpenCLUnavailable saying why the program does not build."""
    cl = _opencl()

    built = _program(device, compute)
    if isinstance(built, OpenCLUnavailable):
        return built
    ctx, program = built
    key = (device.int_ptr, compute)
    if key not in _DEVICE_STATE or _DEVICE_STATE[key][0] is not program:
        kernels = {name: cl.Kernel(program, name) for name in KERNELS.values()}
        _DEVICE_STATE[key] = (program, (ctx, cl.CommandQueue(ctx), kernels, {}))
    return _DEVICE_STATE[key][1]


class SeriesStats:
    """The rule's outcome over a bake: texels per path (the series, the poles' closed form, the direct
    quadrature) and the largest a-priori bound each of the first two enforces."""

    def __init__(self, texels=(0, 0, 0), bounds=(0.0, 0.0)):
        self.texels = list(texels)
        self.bounds = list(bounds)
        self.shared_terms = 0  # Ŵ(mX) values the (cos θ, D) pairs share (0: the texels evaluate the table)

    def add(self, counts, bounds):
        """Fold in per-group counts (groups, 3) and largest bounds (groups, 2)."""
        self.texels = [t + int(c) for t, c in zip(self.texels, np.asarray(counts).sum(axis=0))]
        self.bounds = [max(b, float(m)) for b, m in zip(self.bounds, np.asarray(bounds).max(axis=0, initial=0.0))]

    series_texels = property(lambda self: self.texels[0])
    closed_form_texels = property(lambda self: self.texels[1])
    direct_texels = property(lambda self: self.texels[2])

    def describe(self) -> dict:
        return {
            "series_texels": self.texels[0],
            "closed_form_texels": self.texels[1],
            "direct_texels": self.texels[2],
            "series_bound_rgb_max": self.bounds[0],
            "closed_form_bound_rgb_max": self.bounds[1],
        }


def with_grazing_white(spec, y0: int, rows: np.ndarray) -> np.ndarray:
    """``rows`` (from image row y0) with the corner zoom's total-reflection texels set to exactly 1
    (plan.BakeSpec.grazing_white: the limit there, which no finite cos θ1 evaluates)."""
    rows[spec.grazing_white(y0, y0 + rows.shape[0])] = 1.0
    return rows


class PendingRows:
    """A band being baked: ``result()`` waits for it and returns it (rows, width, 3) in float64."""

    def __init__(self, rows, event=None, keep=(), finish=lambda rows: rows):
        self._rows, self._event, self._keep, self._finish = rows, event, keep, finish

    def result(self) -> np.ndarray:
        if self._event is not None:
            self._event.wait()
            for item in self._keep:
                if isinstance(item, tuple) and (item[1].wait() or item[0][0]):
                    raise RuntimeError(f"{item[0][0]} texels left for a direct pass the plan did not expect")
            self._event = self._keep = None
            self._rows = self._finish(self._rows)
        return self._rows.astype(np.float64, copy=False)


PAIR_TABLE_BYTES = 48 << 20  # most memory the pairs' shared Ŵ(mX) take (more: each texel evaluates the table)


# Texels of a (cos θ, D) pair that share its Ŵ(mX) before a shared table pays (the table costs a pair
# its largest term count in evaluations; each texel then saves its own).
MIN_TEXELS_PER_PAIR = 8


class _BakePlan:
    """A spec's rule outcome on one device: stats, and, when the pairs' Ŵ(mX) fit PAIR_TABLE_BYTES and
    enough texels share each pair, their running term offsets (else None: texels evaluate the table)."""

    def __init__(self, key, stats, pair_terms, texels_per_pair):
        self.key, self.stats = key, stats
        offsets = np.concatenate([[0], np.cumsum(pair_terms, dtype=np.int64)])
        fits = offsets[-1] * 48 <= PAIR_TABLE_BYTES
        self.offsets = offsets.astype(np.int32) if fits and texels_per_pair >= MIN_TEXELS_PER_PAIR else None
        stats.shared_terms = int(offsets[-1]) if self.offsets is not None else 0
        self.buffers = None


_CHUNK = SERIES_CHUNK  # columns or pairs per step of _series_chunks: its temporaries stay bounded
_COLUMN = 24  # REAL per column in the kernel's layout (COLUMN in airy.cl)


def _series_shapes(spec) -> tuple:
    """Shapes of the series kernels' two inputs (_series_chunks): coefficients, film."""
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    return (n_kappa3 * n_eta3 * n_cos, _COLUMN), (n_opd * n_cos, 3)


def _series_chunks(spec, dtype=np.float64):
    """Host inputs of kernels/airy.cl's series in the kernel's layout, as ``dtype``, a chunk of rows at a
    time, so that neither they nor their temporaries scale with the grid on the host: yields (input,
    first row, rows) with input 0 the coefficients, 1 the film (shapes: _series_shapes).

    coefficients (κ3, η3, cos θ, _COLUMN): [s, p] × [C0, K, q, 1 − |q|] (1 − |q| = −1 marking an
    evanescent film), then the column's rule constants (_column_rule), then zeros; film (D, cos θ,
    [X, e^{i2πXν0}]).
    """
    cos_t, opd, kappa3 = (spec.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    eta3 = spec.eta3_columns()  # (η3, cos θ) flattened
    wt = weight_transform(spec.observer, spec.space)
    (n_columns, _), (n_pairs, _) = _series_shapes(spec)
    for start in range(0, n_columns, _CHUNK):
        flat = np.arange(start, min(start + _CHUNK, n_columns))
        column, i_kappa3 = flat % (n_eta3 * n_cos), flat // (n_eta3 * n_cos)
        co = series_coefficients(
            spec.eta1, spec.eta2, cos_t[column % n_cos], 0.0, eta3[column], kappa3[i_kappa3, column % n_cos]
        )
        one_minus_q = np.where(co.in_scope, co.one_minus_q, -1.0)
        block = np.zeros((flat.size, _COLUMN), dtype)
        for p in (0, 1):
            block[:, 6 * p : 6 * p + 6] = np.stack(
                [co.c0[p], co.k[p].real, co.k[p].imag, co.q[p].real, co.q[p].imag, one_minus_q[p]], -1
            )
        block[:, 12:21] = _column_rule(co, wt.mass.max())
        yield 0, start, block
    cos2 = _signed_cos_theta2(spec.eta1, spec.eta2, cos_t).clip(0)
    for start in range(0, n_pairs, _CHUNK):
        flat = np.arange(start, min(start + _CHUNK, n_pairs))
        x_nm = opd[flat // n_cos, flat % n_cos] * cos2[flat % n_cos]
        turn = np.exp(2j * np.pi * NU0_PER_NM * x_nm)
        yield 1, start, np.stack([x_nm, turn.real, turn.imag], -1).astype(dtype)


def _column_rule(co, mass) -> np.ndarray:
    """(n, 9): the rule's constants of each column, float64: |K|/(1 − |q|) (0 where K = 0), |q|, log |q|,
    |K| per polarization (s, p), then the terms after which (Σ_pol |K|/(1 − |q|)) max|q|^m · mass ≤ tol
    (a bound on the series' terms: sup |Ŵ| ≤ mass), +1 for the rounding of the logs."""
    k_abs, q_abs = np.abs(co.k), np.abs(co.q)
    with np.errstate(divide="ignore", invalid="ignore"):
        lead = np.where(k_abs == 0, 0.0, k_abs / co.one_minus_q)
        log_q = np.log(q_abs)
        total = lead.sum(axis=0) * mass
        geometric = np.ceil(np.log(DEFAULT_SERIES_TOLERANCE / total) / np.log(q_abs.max(axis=0))) + 1
    geometric = np.where(total <= DEFAULT_SERIES_TOLERANCE, 0.0, np.where(q_abs.max(axis=0) == 0, 1.0, geometric))
    geometric = np.nan_to_num(geometric, nan=SERIES_BUDGET, posinf=SERIES_BUDGET)  # evanescent: never used
    return np.stack([*lead, *q_abs, *np.nan_to_num(log_q, nan=0.0, neginf=-1e300), *k_abs, geometric], -1)


class OpenCLBackend:
    """kernels/airy.cl on an OpenCL device: the first that builds the kernel and passes its self-check
    among those ``device`` names (see ``devices.find_devices``: one device, or a family such as 'pocl'),
    else $LUTBAKE_DEVICE's, else PYOPENCL_CTX's, else every device (``devices.opencl_devices`` order).

    ``integrator`` 'series' (the bake's default) runs the Fourier series where
    its rule allows, the poles' closed form (kernels/poles.cl) where the film
    propagates and the series would be long, and the direct quadrature for
    what is left (evanescent films, films whose poles are too many); 'direct'
    runs the quadrature on every texel.
    """

    name = "opencl"

    def __init__(self, compute: str = "float64", integrator: str = "series", device=None):
        self.compute = compute
        self.integrator = integrator
        self.dtype = np.float64 if compute == "float64" else np.float32
        reasons = []
        for candidate in _candidate_devices(device):
            self._static = self._series = self._plan = None  # buffers belong to one context
            built = _device_kernels(candidate, compute)
            if isinstance(built, OpenCLUnavailable):
                reasons.append(str(built))
                continue
            self.ctx, self.queue, self._kernels, self._tables = built
            error = _self_check(self, candidate)
            if error <= SELF_CHECK_TOLERANCE[compute]:
                return
            reasons.append(
                f"{device_label(candidate)}: fails the self-check (|ΔR| {error:.2g} against numpy, "
                f"tolerance {SELF_CHECK_TOLERANCE[compute]:g})"
            )
        raise OpenCLUnavailable("; ".join(reasons) or "no OpenCL device found")

    def __getattr__(self, name):
        """The program's kernels as attributes: self.series_kernel is bake_rows_series, …"""
        kernels = self.__dict__.get("_kernels")
        if kernels is not None and name in KERNELS:
            return kernels[KERNELS[name]]
        raise AttributeError(name)

    @property
    def device(self) -> str:
        """The device that runs the kernel, as 'platform / device'."""
        return device_label(self.ctx.devices[0])

    def _run(self, kernel, n_items: int, *args):
        """``kernel`` over ``n_items`` work-items in work-groups of _LOCAL_SIZE (see there), or of the
        most the device allows for that kernel where that is fewer."""
        cl = _opencl()

        local = min(
            _LOCAL_SIZE, kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, self.ctx.devices[0])
        )
        kernel(self.queue, (-(-n_items // local) * local,), (local,), *args, np.int32(n_items))

    def _static_buffers(self, spec):
        cl = _opencl()

        key = spec.content_hash
        if self._static and self._static[0] == key:
            return self._static[1]
        rules = [spec.ladder.rule(k) for k in range(len(spec.ladder.counts))]
        nu = np.concatenate([1.0 / r.wavelength_nm for r in rules])
        weights = np.concatenate([r.weights.ravel() for r in rules])
        cos_t, opd, kappa3 = (spec.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
        cos2 = _signed_cos_theta2(spec.eta1, spec.eta2, cos_t)
        # The phase inputs go in as float-float pairs (exact in float64 mode: lo = 0). D and κ3 per
        # (node, cos θ1 node), row-major: the corner zoom moves them with the incidence.
        arrays = [
            cos_t,
            *_split(cos2, self.dtype),
            *_split(opd.ravel(), self.dtype),
            spec.eta3_columns(),
            kappa3.ravel(),
            *_split(nu, self.dtype),
            weights,
        ]
        mf = cl.mem_flags
        buffers = [
            cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
            for a in arrays
        ]
        self._static = (key, (buffers, spec.ladder.counts[0]))
        return self._static[1]

    def _series_buffers(self, spec):
        """(buffers, scalars) of the series kernels for ``spec`` (built once per spec)."""
        cl = _opencl()

        if self._series and self._series[0] == spec.content_hash:
            return self._series[1]
        wt = weight_transform(spec.observer, spec.space)
        mf = cl.mem_flags
        size = np.dtype(self.dtype).itemsize
        buffers = [cl.Buffer(self.ctx, mf.READ_ONLY, size=rows * width * size) for rows, width in _series_shapes(spec)]
        for which, start, block in _series_chunks(spec, self.dtype):  # chunk by chunk: no host copy of the whole
            cl.enqueue_copy(self.queue, buffers[which], block, device_offset=start * block.shape[1] * size)
        key = ("fourier", spec.observer, spec.space)
        if key not in self._tables:
            table = np.stack([wt.coefficients.real, wt.coefficients.imag], -1)  # (intervals, 3, 6, 2)
            tail = np.array([wt.mass.max(), wt.edge.max(), wt.variation.max()])
            self._tables[key] = [
                cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
                for a in (table, tail)
            ]
        table_buf, tail_buf = self._tables[key]
        real = self.dtype
        args = [
            *buffers,
            table_buf,
            np.int32(wt.coefficients.shape[0]),
            real(wt.step_nm),
            tail_buf,
            real(wt.interpolation_bound.max()),
            real(DEFAULT_SERIES_TOLERANCE),
            np.int32(SERIES_BUDGET),
        ]
        self._series = (spec.content_hash, args)
        return args

    def _cauchy_buffers(self, spec):
        """The closed form's tables (lutbake/spectral/poles.py) for the spec's colour weights (built once per
        observer and space)."""
        cl = _opencl()

        from lutbake.spectral.poles import cauchy_table, chebyshev_rule

        key = ("cauchy", spec.observer, spec.space)
        if key in self._tables:
            return self._tables[key]
        table, rule = cauchy_table(*key[1:]), chebyshev_rule(*key[1:])
        arrays = [np.stack([t.real, t.imag], -1) for t in (table.shallow, table.deep)]
        arrays += [
            np.concatenate([table.knot_a, table.knot_b]),
            np.concatenate([rule.wavelength_nm[None], rule.weights]),
        ]
        mf = cl.mem_flags
        buffers = [
            cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
            for a in arrays
        ]
        self._tables[key] = [*buffers, self.dtype(table.bound.max()), self.dtype(rule.mass.max())]
        return self._tables[key]

    def _band_args(self, spec, y0):
        width, _ = spec.image_size
        n_cos, n_opd, _, _ = spec.shape
        return [np.int32(n_cos), np.int32(n_opd), np.int32(width), np.int32(y0), *self._series_buffers(spec)]

    def _bake_plan(self, spec) -> "_BakePlan":
        """The rule over the whole grid (plan_rows, band by band): its outcome and each (cos θ, D)
        pair's series terms; the pairs' Ŵ(mX) when they fit one table (built once per spec)."""
        cl = _opencl()

        if self._plan and self._plan.key == spec.content_hash:
            return self._plan
        stats = SeriesStats()
        n_cos, n_opd, _, _ = spec.shape
        pair_terms = np.zeros(n_cos * n_opd, np.int32)
        terms_buf = cl.Buffer(self.ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=pair_terms)
        for y0, y1 in spec.row_chunks():
            stats.add(*self._plan_band(spec, y0, y1, terms_buf))
        cl.enqueue_copy(self.queue, pair_terms, terms_buf)
        self._plan = _BakePlan(spec.content_hash, stats, pair_terms, spec.shape[2] * spec.shape[3])
        return self._plan

    def _plan_band(self, spec, y0, y1, terms_buf) -> tuple:
        """The rule over rows [y0, y1): ([[series, closed-form, direct texels]], [[their largest bounds]]),
        the pairs' term counts raised in ``terms_buf``."""
        cl = _opencl()

        cells = (y1 - y0) * spec.image_size[0]
        mf = cl.mem_flags
        rest = cl.Buffer(self.ctx, mf.READ_WRITE, max(1, cells) * 4)
        rest_count = cl.Buffer(self.ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=np.zeros(1, np.int32))
        bounds = cl.Buffer(self.ctx, mf.READ_WRITE, max(1, cells) * np.dtype(self.dtype).itemsize)
        self._run(self.plan_kernel, cells, *self._band_args(spec, y0), terms_buf, rest, rest_count, bounds)
        left, series_bound = self._count(rest_count), self._max(bounds, cells)
        if not left:
            return [[cells, 0, 0]], [[series_bound, 0.0]]
        path, bound = np.empty(left, np.int8), np.empty(left, self.dtype)
        path_buf, bound_buf = (cl.Buffer(self.ctx, mf.WRITE_ONLY, a.nbytes) for a in (path, bound))
        self._run(
            self.plan_closed_kernel,
            left,
            *self._band_args(spec, y0),
            *self._cauchy_buffers(spec),
            rest,
            rest_count,
            path_buf,
            bound_buf,
        )
        cl.enqueue_copy(self.queue, path, path_buf)
        cl.enqueue_copy(self.queue, bound, bound_buf)
        closed, direct = np.bincount(path, minlength=3)[1:3]
        return [[cells - left, closed, direct]], [[series_bound, float(bound[path == 1].max(initial=0.0))]]

    def series_plan(self, spec) -> SeriesStats:
        """The rule's outcome over the whole grid (plan_rows: bounds only, no integration)."""
        if self.integrator == "direct":
            return NumpyBackend.series_plan(spec)
        return self._bake_plan(spec).stats

    def _pair_table(self, spec, plan) -> list:
        """The pairs' shared Ŵ(mX) for bake_rows_series (pair_transform, once per spec): [offsets, values]."""
        cl = _opencl()

        if plan.buffers is None:
            mf = cl.mem_flags
            offset_buf = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=plan.offsets)
            table = cl.Buffer(
                self.ctx, mf.READ_WRITE, max(1, 6 * int(plan.offsets[-1])) * np.dtype(self.dtype).itemsize
            )
            args = self._series_buffers(spec)
            self._run(self.pair_kernel, plan.offsets.size - 1, args[1], offset_buf, *args[2:5], table)
            plan.buffers = [offset_buf, table]
        return plan.buffers

    def bake_rows(self, spec, y0, y1):
        return self.begin_rows(spec, y0, y1).result()

    def begin_rows(self, spec, y0, y1) -> "PendingRows":
        """Enqueue the band [y0, y1) and return at once (unless some of its texels take the direct
        quadrature, whose rule levels the host computes): the caller writes the previous band while the
        device works."""
        cl = _opencl()

        width, _ = spec.image_size
        cells = (y1 - y0) * width
        out = np.empty((y1 - y0, width, 3), self.dtype)
        mf = cl.mem_flags
        out_buf = cl.Buffer(self.ctx, mf.READ_WRITE, out.nbytes)
        keep = [out_buf]
        if self.integrator == "direct":
            keep += self._direct(spec, y0, np.arange(cells, dtype=np.int32), spec.row_levels(y0, y1), out_buf)
        else:
            keep += self._series_passes(spec, y0, y1, out_buf)
        return PendingRows(
            out,
            cl.enqueue_copy(self.queue, out, out_buf, is_blocking=False),
            keep,
            lambda rows: with_grazing_white(spec, y0, rows),
        )

    def _series_passes(self, spec, y0, y1, out_buf) -> list:
        """Enqueue the series, the closed form at what it leaves and (where the plan expects any) the
        direct quadrature at what that leaves; the buffers to keep until they are done."""
        cl = _opencl()

        plan = self._bake_plan(spec)
        cells = (y1 - y0) * spec.image_size[0]
        mf = cl.mem_flags
        lists = [cl.Buffer(self.ctx, mf.READ_WRITE, max(1, cells) * 4) for _ in range(2)]
        counts = [
            cl.Buffer(self.ctx, mf.READ_WRITE | mf.COPY_HOST_PTR, hostbuf=np.zeros(1, np.int32)) for _ in range(2)
        ]
        keep = lists + counts
        if plan.offsets is not None:
            self._run(
                self.series_kernel,
                cells,
                *self._band_args(spec, y0),
                *self._pair_table(spec, plan),
                out_buf,
                lists[0],
                counts[0],
            )
        else:
            self._run(self.series_table_kernel, cells, *self._band_args(spec, y0), out_buf, lists[0], counts[0])
        if plan.stats.closed_form_texels or plan.stats.direct_texels:
            self._run(
                self.closed_kernel,
                cells,
                *self._band_args(spec, y0),
                *self._cauchy_buffers(spec),
                lists[0],
                counts[0],
                out_buf,
                lists[1],
                counts[1],
            )
        left = self._count(counts[1]) if plan.stats.direct_texels else 0
        if left:
            texels = np.empty(left, np.int32)
            cl.enqueue_copy(self.queue, texels, lists[1])
            texels.sort()
            params = [np.ravel(p)[texels] for p in spec.cell_params(y0, y1)]
            return keep + self._direct(spec, y0, texels, spec.cell_levels(*params), out_buf)
        # the plan said none: check that the band agrees (the same rule ran)
        unplanned = np.zeros(1, np.int32)
        return keep + [(unplanned, cl.enqueue_copy(self.queue, unplanned, counts[1], is_blocking=False))]

    def _max(self, values, count: int) -> float:
        """The largest of ``count`` values in a device buffer (max_chunks, then the host)."""
        cl = _opencl()

        chunk = 4096
        parts = np.empty(max(1, -(-count // chunk)), self.dtype)
        out = cl.Buffer(self.ctx, cl.mem_flags.WRITE_ONLY, parts.nbytes)
        self._run(self.max_kernel, parts.size, values, np.int32(count), np.int32(chunk), out)
        cl.enqueue_copy(self.queue, parts, out)
        return float(parts.max())

    def _count(self, buffer) -> int:
        cl = _opencl()

        count = np.empty(1, np.int32)
        cl.enqueue_copy(self.queue, count, buffer)
        return int(count[0])

    def _direct(self, spec, y0, texels, levels, out_buf) -> list:
        """Enqueue the direct quadrature at ``texels`` (band indices) of the band starting at row y0; the
        buffers it reads (to keep until it is done)."""
        cl = _opencl()

        buffers, n_min = self._static_buffers(spec)
        n_cos, n_opd, _, _ = spec.shape
        mf = cl.mem_flags
        texel_buf, level_buf = (
            cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a))
            for a in (texels.astype(np.int32), levels.astype(np.int32))
        )
        real = self.dtype
        self._run(
            self.direct_kernel,
            texels.size,
            *buffers,
            texel_buf,
            level_buf,
            real(spec.eta1),
            real(spec.eta2),
            np.int32(n_cos),
            np.int32(n_opd),
            np.int32(spec.image_size[0]),
            np.int32(y0),
            np.int32(n_min),
            out_buf,
        )
        return [texel_buf, level_buf]

    def evaluate(self, spec, stack: FilmPoints):
        """RGB (P, 3) of P stacks of the spec's film (flat fields): the kernel's R at each one's rule nodes."""
        levels = _levels(spec, stack)
        out = np.empty((levels.size, 3))
        for level in np.unique(levels):
            rule = spec.ladder.rule(level)
            cells = np.flatnonzero(levels == level)
            out[cells] = self.reflectance(subset(stack, cells).as_column(), rule.wavelength_nm) @ rule.weights.T
        return out

    def reflectance(self, stack: FilmPoints, wavelength_nm):
        """The kernel's unpolarized R of the stacks at ``wavelength_nm`` (broadcast as
        optics.film_reflectance; one ambient η1, named materials taken at each wavelength): its
        physics, node by node."""
        cl = _opencl()

        eta1 = float(np.ravel(stack.eta1)[0])
        stack.require("kernel", eta1=eta1)  # one ambient index per launch
        eta2, eta3, kappa3 = stack.indices(wavelength_nm)
        cols = np.broadcast_arrays(
            stack.cos_theta, 2.0 * eta2 * stack.thickness_nm, eta2, eta3, kappa3, np.asarray(wavelength_nm, np.float64)
        )
        shape = cols[0].shape
        cos1, opd, e2, e3, k3, lam = (np.ravel(c) for c in cols)
        arrays = [
            cos1,
            *_split(_signed_cos_theta2(eta1, e2, cos1), self.dtype),
            *_split(opd, self.dtype),
            e2,
            e3,
            k3,
            *_split(1.0 / lam, self.dtype),
        ]
        mf = cl.mem_flags
        bufs = [
            cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
            for a in arrays
        ]
        out = np.empty(cos1.size, self.dtype)
        out_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, out.nbytes)
        self._run(self.points_kernel, cos1.size, *bufs, self.dtype(eta1), out_buf)
        cl.enqueue_copy(self.queue, out, out_buf)
        return out.astype(np.float64).reshape(shape)

    def stack_colour(self, eta1, cos_theta, thickness_nm, node_indices, rule):
        """RGB (P, 3) of one film stack at points (cos θ1, d), by ``rule`` with the film's and base's
        indices per node (``node_indices`` = (η2, η3, κ3), each (N,): dispersive materials): the
        kernel's reflectance summed on the device, its Fresnel side once per distinct cos θ1 × node."""
        cl = _opencl()

        eta2, eta3, kappa3 = (np.broadcast_to(np.asarray(v, np.float64), (rule.count,)) for v in node_indices)
        thickness_nm = np.asarray(thickness_nm, np.float64)
        cos_values, cos_index = np.unique(np.asarray(cos_theta, np.float64), return_inverse=True)
        mf = cl.mem_flags

        def buffer(a, dtype=self.dtype):
            return cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, dtype))

        cos2 = _signed_cos_theta2(eta1, eta2[None, :], cos_values[:, None]).ravel()
        cos2_hi, cos2_lo = (buffer(a) for a in _split(cos2, self.dtype))
        cos1, eta2_buf = buffer(cos_values), buffer(eta2)
        real = self.dtype
        terms = cl.Buffer(
            self.ctx, mf.READ_WRITE, cos_values.size * rule.count * _STACK_TERMS * np.dtype(real).itemsize
        )
        self._run(
            self.stack_terms_kernel,
            cos_values.size * rule.count,
            cos1,
            cos2_hi,
            eta2_buf,
            buffer(eta3),
            buffer(kappa3),
            real(eta1),
            real(thickness_nm.max()),
            np.int32(rule.count),
            terms,
        )
        n_blocks = -(-rule.count // _STACK_BLOCK)
        out = np.empty((n_blocks, cos_index.size, 3), self.dtype)
        out_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, out.nbytes)
        self._run(
            self.stack_kernel,
            out.size // 3,
            cos1,
            cos2_hi,
            cos2_lo,
            terms,
            buffer(cos_index, np.int32),
            *(buffer(a) for a in _split(thickness_nm, self.dtype)),
            eta2_buf,
            *(buffer(a) for a in _split(1.0 / rule.wavelength_nm, self.dtype)),
            buffer(rule.weights),
            np.int32(rule.count),
            np.int32(_STACK_BLOCK),
            np.int32(cos_index.size),
            out_buf,
        )
        cl.enqueue_copy(self.queue, out, out_buf)
        return out.astype(np.float64).sum(axis=0)


class DeviceCannotRun(ParameterError, OpenCLUnavailable):
    """The OpenCL device named by ``device`` (or $LUTBAKE_DEVICE) does not build the kernel or fails its
    self-check: bad input (the CLI's exit 2), not a reason to fall back to numpy."""


def backend(name: str = "auto", compute: str = "float64", integrator: str = "series", device=None):
    """The integrator for ``name`` ('opencl', 'numpy' or 'auto': OpenCL, else numpy with a warning);
    ``integrator`` picks the OpenCL kernel ('series' or 'direct', see OpenCLBackend), ``device``
    the OpenCL device (``devices.find_devices``). A device named here or by $LUTBAKE_DEVICE that cannot run
    raises DeviceCannotRun, even under 'auto': only the default device falls back."""
    if name == "numpy":
        return NumpyBackend()
    chosen = device or os.environ.get("LUTBAKE_DEVICE")
    try:
        return OpenCLBackend(compute, integrator, device)
    except (OpenCLUnavailable, ImportError) as exc:
        if chosen:  # a device the user named is not swapped for another path behind their back
            raise DeviceCannotRun(
                "{device} {selector} cannot run the kernel ({reason}): name another "
                "(`lutbake devices` lists them) or omit it",
                selector=repr(chosen),
                reason=exc,
            ) from None
        if name == "opencl":
            raise
        warnings.warn(
            f"OpenCL unavailable ({exc}); baking with the numpy path, which is much slower",
            RuntimeWarning,
            stacklevel=2,
        )
        return NumpyBackend()


def survey_devices(throughput_spec=None) -> list:
    """Every OpenCL device: whether the kernel builds (float64, float32), passes the self-check,
    and, given a spec, its measured cells per second baking it (after a warm-up band)."""
    import time

    try:
        devices = opencl_devices() or ["no OpenCL platform offers a device"]
    except (OpenCLUnavailable, ImportError) as exc:
        devices = [str(exc)]
    if isinstance(devices[0], str):
        return [{"index": None, "key": "opencl", "label": "no OpenCL device", "error": devices[0]}]
    default = _default_device_key()
    rows = []
    for index, device in enumerate(devices):
        key, label = device_key(device, devices), device_label(device)
        row = {
            "index": index,
            "key": key,
            "label": label,
            "default": key == default,
            "runtime": dataclasses.asdict(runtime_of(device)),
        }
        for compute in ("float64", "float32"):
            try:
                fast = OpenCLBackend(compute, device=str(index))
                row[compute] = {"builds": True, "self_check_error": _self_check(fast, device)}
            except OpenCLUnavailable as exc:  # one device tried: its reason, without its label
                row[compute] = {"builds": False, "error": str(exc).removeprefix(f"{label}: ")}
        if throughput_spec is not None and row["float64"].get("builds"):
            fast = OpenCLBackend("float64", device=str(index))
            fast.bake_rows(throughput_spec, 0, 1)
            start = time.perf_counter()
            bake_rows_all(fast, throughput_spec)
            row["cells_per_second"] = throughput_spec.cells / (time.perf_counter() - start)
        rows.append(row)
    return rows


def _default_device_key():
    """Key of the device ``OpenCLBackend()`` picks, or None."""
    try:
        return device_key(OpenCLBackend("float64").ctx.devices[0])
    except (OpenCLUnavailable, ImportError):
        return None


def bake_rows_all(integrator, spec) -> np.ndarray:
    """The whole packed image (height, width, 3) of ``spec`` in float64, band by band."""
    return np.concatenate([integrator.bake_rows(spec, y0, y1) for y0, y1 in spec.row_chunks()])
