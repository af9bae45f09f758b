"""Integrate a bake plan to RGB, band by band: the OpenCL kernel or the numpy path.

Both return the RGB of every texel of a band of image rows, an array
(rows, width, 3):

* ``OpenCLBackend`` runs kernels/airy.cl through pyopencl, by default on
  PoCL's CPU device from PyPI; ``PYOPENCL_CTX`` picks any other platform
  (a GPU's driver runs the same source unchanged). The program is built
  once per process and compute precision. By default each texel is summed
  as the exact Fourier series (lutbake/fourier.py) where its rule allows,
  and integrated by the spectral rule elsewhere.
* ``NumpyBackend`` evaluates optics.film_reflectance (the ground truth's
  float64 physics) at the rule's nodes: the reference for the kernel in
  tests, and the fallback where no OpenCL platform exists.
"""

from __future__ import annotations

import contextlib
import functools
import os
import sys
import tempfile
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import OpenCLUnavailable
from .fourier import (DEFAULT_SERIES_TOLERANCE, NU0_PER_NM, SERIES_BUDGET, series_coefficients, series_colour,
                      weight_transform)
from .optics import film_reflectance, normal_admittance
from .points import FilmPoints
from .reference import subset
from .usercache import pyopencl_caches_where_writable

pyopencl_caches_where_writable()   # before pyopencl is imported: it reads PYOPENCL_NO_CACHE once

__all__ = ["NumpyBackend", "OpenCLBackend", "backend", "OpenCLUnavailable", "opencl_devices", "find_device",
           "device_key", "device_label", "self_check_error"]


class NumpyBackend:
    """float64 numpy evaluation of the exact Airy reflectance at each texel's rule nodes."""

    name = "numpy"
    device = "numpy / float64 (host CPU)"
    _CELLS_X_NODES = 2_000_000

    def bake_rows(self, spec, y0, y1):
        stacks = spec.texel_stacks(a.ravel() for a in spec.cell_params(y0, y1))
        return self.evaluate(spec, stacks).reshape(y1 - y0, -1, 3)

    @staticmethod
    def series_plan(spec) -> "SeriesStats":
        """This path integrates every texel directly."""
        stats = SeriesStats()
        stats.add(np.full(spec.cells, -1), np.zeros(spec.cells))
        return stats

    def evaluate(self, spec, stack: FilmPoints):
        """RGB (P, 3) of P stacks of the spec's film (flat fields), each at its texel's rule nodes."""
        levels = _levels(spec, stack)
        out = np.empty((levels.size, 3))
        for level in np.unique(levels):
            rule = spec.ladder.rule(level)
            cells = np.flatnonzero(levels == level)
            step = max(1, self._CELLS_X_NODES // rule.count)
            for s in range(0, cells.size, step):
                i = cells[s:s + step]
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


@contextlib.contextmanager
def _intel_cpu_runtime_visible():
    """Make Intel's CPU OpenCL runtime (PyPI: opencl-rt) visible to the platform query inside.

    PoCL 3.0 from PyPI compiles kernels with LLVM 14, which cannot name CPUs
    newer than it (AMD family 1Ah, Zen 5: "unknown target CPU 'generic'").
    The test extra installs Intel's CPU runtime into the environment's lib/;
    registering it gives such machines a second OpenCL CPU device that runs
    the same kernel source. The ICD loader reads its vendor list once, at the
    process's first platform query, so the .icd file (in a private temporary
    folder) and OCL_ICD_VENDORS exist only for that query and are gone after
    it. An explicit OCL_ICD_VENDORS is left alone; a process that queried
    platforms before lutbake did sees only the runtimes it registered itself.
    """
    lib = Path(sys.prefix) / "lib" / "libintelocl.so"
    if "OCL_ICD_VENDORS" in os.environ or not lib.is_file():
        yield
        return
    with tempfile.TemporaryDirectory(prefix="lutbake-icd-") as vendors:
        (Path(vendors) / "intel-cpu.icd").write_text(f"{lib}\n")
        os.environ["OCL_ICD_VENDORS"] = vendors
        try:
            yield
        finally:
            del os.environ["OCL_ICD_VENDORS"]


RUNTIME_KEYS = {"Portable Computing Language": "pocl", "Intel(R) OpenCL": "intel"}


def device_key(device) -> str:
    """Short stable name of a device: its runtime ('pocl', 'intel', …), plus ':N' past the first."""
    platform = device.platform.name.strip()
    key = RUNTIME_KEYS.get(platform, platform.split()[0].lower())
    index = device.platform.get_devices().index(device)
    return key if index == 0 else f"{key}:{index}"


def device_label(device) -> str:
    """'platform / device' as the runtime names them."""
    return f"{device.platform.name.strip()} / {device.name.strip()}"


def opencl_devices() -> list:
    """Every OpenCL device, PoCL's first (the design's runtime), then the rest in platform order."""
    import pyopencl as cl

    try:
        with _intel_cpu_runtime_visible():
            platforms = cl.get_platforms()
    except cl.Error as exc:
        raise OpenCLUnavailable(f"no OpenCL platform: {exc}") from None
    platforms.sort(key=lambda p: "Portable Computing Language" not in p.name)
    return [d for p in platforms for d in p.get_devices()]


def _candidate_devices(selector=None):
    """Devices to try, in order: the one ``selector`` (or $LUTBAKE_DEVICE) names, else the one
    PYOPENCL_CTX names, else every device (``opencl_devices`` order)."""
    import pyopencl as cl

    selector = selector or os.environ.get("LUTBAKE_DEVICE")
    if selector:
        return [find_device(selector)]
    if os.environ.get("PYOPENCL_CTX"):
        try:
            with _intel_cpu_runtime_visible():
                return [cl.create_some_context(interactive=False).devices[0]]
        except (cl.Error, RuntimeError, ValueError) as exc:  # pyopencl's words for a selector it cannot match
            raise ValueError(f"PYOPENCL_CTX={os.environ['PYOPENCL_CTX']!r} names no OpenCL device ({exc}): "
                             "unset it, or give a platform:device index such as 0:0") from None
    return opencl_devices()


def find_device(selector: str):
    """The device a selector names: its index in ``opencl_devices()``, its key, or a
    case-insensitive part of its label (e.g. '0', 'pocl', 'intel')."""
    devices = opencl_devices()
    text = str(selector).strip().lower()
    if text.isdigit() and int(text) < len(devices):
        return devices[int(text)]
    exact = [d for d in devices if device_key(d) == text]
    found = exact or [d for d in devices if text in device_label(d).lower()]
    if len(found) != 1:
        known = ", ".join(f"{i} ({device_key(d)}: {device_label(d)})" for i, d in enumerate(devices))
        state = "matches no" if not found else "matches more than one"
        raise ValueError(f"device {selector!r} {state} OpenCL device; devices: {known or 'none'}")
    return found[0]


def _build(device, compute: str):
    import pyopencl as cl

    if compute == "float64" and "cl_khr_fp64" not in device.extensions:
        raise OpenCLUnavailable(f"device {device.name.strip()!r} has no float64: bake with compute float32")
    ctx = cl.Context([device])
    source = resources.files("lutbake").joinpath("kernels/airy.cl").read_text()
    options = ["-DLUTBAKE_FP64"] if compute == "float64" else []
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
_SELF_CHECK = np.array([
    # cos θ1, D (nm), η3, κ3, λ (nm)
    [1e-6, 0.0, 1.0, 1e-12, 550.0], [1e-6, 1e-9, 1.0, 1e-12, 400.0], [0.0, 500.0, 1.5, 0.0, 500.0],
    [0.3, 1e5, 2.0, 3.0, 700.0], [1.0, 800.0, 1.0, 0.0, 450.0], [0.05, 4000.0, 0.2, 3.5, 610.0],
    [0.7, 250.0, 1.5, 1e-9, 380.0], [1e-12, 1e4, 3.0, 100.0, 820.0],
])
SELF_CHECK_TOLERANCE = {"float64": 1e-10, "float32": 2e-5}
# Nodes per work-item of stack_rgb: its few stiff points on the finest rules still spread over every core.
_STACK_BLOCK = 256
# One work-group size for every launch (global sizes padded to it; the kernels return past their count):
# PoCL builds a kernel's work-group function per distinct local size, which it picks per global size when
# left to choose — ~0.2 s each, and a scene's trials and levels meet dozens of sizes.
_LOCAL_SIZE = 64
_STACK_TERMS = 18   # reals per (cos θ1, node) in stack_terms' output (STACK_TERMS in airy.cl)


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
    from .plan import Axis, BakeSpec

    cos1, opd, eta3, kappa3, lam = _SELF_CHECK.T
    worst = 0.0
    for eta1, eta2 in ((1.0, 1.5), (1.6, 1.2)):
        stack = FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos1, opd_nm=opd, eta3=eta3, kappa3=kappa3)
        fast = backend.reflectance(stack, lam)
        ref = film_reflectance(stack, lam)[2]
        worst = max(worst, float(np.max(np.abs(fast - ref))))
    grid = BakeSpec(eta2=1.5, compute=backend.compute, axes=(
        Axis("cos_theta", 0.0, 1.0, 4), Axis("opd_nm", 0.0, 2000.0, 4), Axis("eta3", 1.0, 3.0, 2),
        Axis("kappa3", 0.0, 4.0, 2)))
    expected = bake_rows_all(NumpyBackend(), grid)
    if getattr(backend, "integrator", "direct") == "series":
        stacks = grid.texel_stacks(np.ravel(p) for p in grid.cell_params(0, grid.image_size[1]))
        series = series_colour(stacks, grid.observer, grid.space).values
        expected = np.where(np.isnan(series), expected.reshape(-1, 3), series).reshape(expected.shape)
    return max(worst, float(np.max(np.abs(bake_rows_all(backend, grid) - expected))))


@functools.lru_cache(maxsize=16)
def _program(device, compute: str):
    """(context, program) built for one device, or the OpenCLUnavailable saying why not."""
    import pyopencl as cl

    try:
        return _build(device, compute)
    except (cl.Error, OpenCLUnavailable) as exc:
        lines = str(exc).strip().splitlines() or ["build failed"]
        return OpenCLUnavailable(f"{device_label(device)}: {next((l for l in lines if 'error' in l), lines[0])}")


class SeriesStats:
    """The series rule over a bake: its method mix and the largest a-priori bound it enforces."""

    def __init__(self):
        self.series_texels = self.direct_texels = 0
        self.bound_rgb_max = 0.0

    def add(self, cap, bound):
        taken = cap >= 0
        self.series_texels += int(taken.sum())
        self.direct_texels += int(cap.size - taken.sum())
        self.bound_rgb_max = max(self.bound_rgb_max, float(bound[taken].max(initial=0.0)))

    def describe(self) -> dict:
        return {"series_texels": self.series_texels, "direct_texels": self.direct_texels,
                "series_bound_rgb_max": self.bound_rgb_max}


def _series_arrays(spec):
    """Host inputs of kernels/airy.cl's series: (coefficients, film) in the kernel's layout, float64.

    coefficients (κ3, η3, cos θ, [s, p] × [C0, K, q, 1 − |q|]), 1 − |q| = −1
    marking an evanescent film; film (D, cos θ, [X, e^{i2πXν0}]).
    """
    ax = {a.name: a.values() for a in spec.axes}
    n_cos, n_eta3 = ax["cos_theta"].size, ax["eta3"].size
    cos_t = np.broadcast_to(ax["cos_theta"][:, None, None], (n_cos, n_eta3, ax["kappa3"].size))
    e3 = np.broadcast_to(spec.eta3_columns().reshape(n_eta3, n_cos).T[:, :, None], cos_t.shape)
    k3 = np.broadcast_to(ax["kappa3"][None, None, :], cos_t.shape)
    co = series_coefficients(spec.eta1, spec.eta2, cos_t.ravel(), 0.0, e3.ravel(), k3.ravel())
    one_minus_q = np.where(co.in_scope, co.one_minus_q, -1.0)
    per_pol = [np.stack([co.c0[p], co.k[p].real, co.k[p].imag, co.q[p].real, co.q[p].imag, one_minus_q[p]], -1)
               for p in (0, 1)]
    coefficients = np.concatenate(per_pol, -1).reshape(cos_t.shape + (12,)).transpose(2, 1, 0, 3)
    x_nm = ax["opd_nm"][:, None] * (_signed_cos_theta2(spec.eta1, spec.eta2, ax["cos_theta"]).clip(0))[None, :]
    turn = np.exp(2j * np.pi * NU0_PER_NM * x_nm)
    film = np.stack([x_nm, turn.real, turn.imag], -1)
    return coefficients, film


class OpenCLBackend:
    """kernels/airy.cl on an OpenCL device: the one ``device`` names (see ``find_device``),
    else $LUTBAKE_DEVICE's, else PYOPENCL_CTX's, else the first that builds the kernel and
    passes its self-check (PoCL first).

    ``integrator`` 'series' (the bake's default) runs the Fourier series where
    its rule allows and the direct quadrature elsewhere (bake_rows_series);
    'direct' runs the quadrature on every texel (bake_rows).
    """

    name = "opencl"

    def __init__(self, compute: str = "float64", integrator: str = "series", device=None):
        import pyopencl as cl

        self.compute = compute
        self.integrator = integrator
        self.dtype = np.float64 if compute == "float64" else np.float32
        reasons = []
        for candidate in _candidate_devices(device):
            self._static = self._series = None   # buffers belong to one device's context
            built = _program(candidate, compute)
            if isinstance(built, OpenCLUnavailable):
                reasons.append(str(built))
                continue
            self.ctx, program = built
            self.kernel = cl.Kernel(program, "bake_rows")
            self.series_kernel = cl.Kernel(program, "bake_rows_series")
            self.plan_kernel = cl.Kernel(program, "plan_rows")
            self.points_kernel = cl.Kernel(program, "reflectance_points")
            self.stack_terms_kernel = cl.Kernel(program, "stack_terms")
            self.stack_kernel = cl.Kernel(program, "stack_rgb")
            self.queue = cl.CommandQueue(self.ctx)
            error = _self_check(self, candidate)
            if error <= SELF_CHECK_TOLERANCE[compute]:
                return
            reasons.append(f"{device_label(candidate)}: fails the self-check (|ΔR| {error:.2g} against numpy, "
                           f"tolerance {SELF_CHECK_TOLERANCE[compute]:g})")
        raise OpenCLUnavailable("; ".join(reasons) or "no OpenCL device found")

    @property
    def device(self) -> str:
        """The device that runs the kernel, as 'platform / device'."""
        return device_label(self.ctx.devices[0])

    def _run(self, kernel, n_items: int, *args):
        """``kernel`` over ``n_items`` work-items in work-groups of _LOCAL_SIZE (see there), or of the
        most the device allows for that kernel where that is fewer."""
        import pyopencl as cl

        local = min(_LOCAL_SIZE, kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE,
                                                            self.ctx.devices[0]))
        kernel(self.queue, (-(-n_items // local) * local,), (local,), *args, np.int32(n_items))

    def _static_buffers(self, spec):
        import pyopencl as cl

        key = spec.content_hash
        if self._static and self._static[0] == key:
            return self._static[1]
        rules = [spec.ladder.rule(k) for k in range(len(spec.ladder.counts))]
        nu = np.concatenate([1.0 / r.wavelength_nm for r in rules])
        weights = np.concatenate([r.weights.ravel() for r in rules])
        ax = {a.name: a.values() for a in spec.axes}
        cos2 = _signed_cos_theta2(spec.eta1, spec.eta2, ax["cos_theta"])
        # The phase inputs go in as float-float pairs (exact in float64 mode: lo = 0).
        arrays = [ax["cos_theta"], *_split(cos2, self.dtype), *_split(ax["opd_nm"], self.dtype),
                  spec.eta3_columns(), ax["kappa3"], *_split(nu, self.dtype), weights]
        mf = cl.mem_flags
        buffers = [cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR,
                             hostbuf=np.ascontiguousarray(a, self.dtype)) for a in arrays]
        self._static = (key, (buffers, spec.ladder.counts[0]))
        return self._static[1]

    def _series_buffers(self, spec):
        """(buffers, scalars) of the series kernel for ``spec`` (built once per spec)."""
        import pyopencl as cl

        if self._series and self._series[0] == spec.content_hash:
            return self._series[1]
        wt = weight_transform(spec.observer, spec.space)
        table = np.stack([wt.coefficients.real, wt.coefficients.imag], -1)   # (intervals, 3, 6, 2)
        tail = np.array([wt.mass.max(), wt.edge.max(), wt.variation.max()])
        mf = cl.mem_flags
        buffers = [cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
                   for a in (*_series_arrays(spec), table)]
        tail_buf = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=tail.astype(self.dtype))
        real = self.dtype
        args = [*buffers, np.int32(table.shape[0]), real(wt.step_nm), tail_buf,
                real(wt.interpolation_bound.max()), real(DEFAULT_SERIES_TOLERANCE), np.int32(SERIES_BUDGET)]
        self._series = (spec.content_hash, args)
        return args

    def series_plan(self, spec) -> SeriesStats:
        """The series rule's outcome over the whole grid (plan_rows: bounds only, no integration)."""
        import pyopencl as cl

        if self.integrator == "direct":
            return NumpyBackend.series_plan(spec)
        stats = SeriesStats()
        width, _ = spec.image_size
        n_cos, n_opd, _, _ = spec.shape
        mf = cl.mem_flags
        for y0, y1 in spec.row_chunks():
            cells = (y1 - y0) * width
            cap, bound = np.empty(cells, np.int32), np.empty(cells, self.dtype)
            cap_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, cap.nbytes)
            bound_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, bound.nbytes)
            self._run(self.plan_kernel, cells, np.int32(n_cos), np.int32(n_opd), np.int32(width), np.int32(y0),
                      *self._series_buffers(spec), cap_buf, bound_buf)
            cl.enqueue_copy(self.queue, cap, cap_buf)
            cl.enqueue_copy(self.queue, bound, bound_buf)
            stats.add(cap, bound)
        return stats

    def bake_rows(self, spec, y0, y1):
        import pyopencl as cl

        buffers, n_min = self._static_buffers(spec)
        width, _ = spec.image_size
        n_cos, n_opd, _, _ = spec.shape
        cells = (y1 - y0) * width
        levels = spec.row_levels(y0, y1)
        mf = cl.mem_flags
        level_buf = cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=levels)
        out = np.empty((y1 - y0, width, 3), self.dtype)
        out_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, out.nbytes)
        real = self.dtype
        args = [*buffers, level_buf, real(spec.eta1), real(spec.eta2),
                np.int32(n_cos), np.int32(n_opd), np.int32(width), np.int32(y0), np.int32(n_min)]
        if self.integrator == "direct":
            self._run(self.kernel, cells, *args, out_buf)
        else:
            self._run(self.series_kernel, cells, *args, *self._series_buffers(spec), out_buf)
        cl.enqueue_copy(self.queue, out, out_buf)
        out_buf.release()
        level_buf.release()
        return out.astype(np.float64, copy=False)

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
        import pyopencl as cl

        eta1 = float(np.ravel(stack.eta1)[0])
        stack.require("kernel", eta1=eta1)  # one ambient index per launch
        eta2, eta3, kappa3 = stack.indices(wavelength_nm)
        cols = np.broadcast_arrays(stack.cos_theta, 2.0 * eta2 * stack.thickness_nm, eta2, eta3, kappa3,
                                   np.asarray(wavelength_nm, np.float64))
        shape = cols[0].shape
        cos1, opd, e2, e3, k3, lam = (np.ravel(c) for c in cols)
        arrays = [cos1, *_split(_signed_cos_theta2(eta1, e2, cos1), self.dtype), *_split(opd, self.dtype),
                  e2, e3, k3, *_split(1.0 / lam, self.dtype)]
        mf = cl.mem_flags
        bufs = [cl.Buffer(self.ctx, mf.READ_ONLY | mf.COPY_HOST_PTR, hostbuf=np.ascontiguousarray(a, self.dtype))
                for a in arrays]
        out = np.empty(cos1.size, self.dtype)
        out_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, out.nbytes)
        self._run(self.points_kernel, cos1.size, *bufs, self.dtype(eta1), out_buf)
        cl.enqueue_copy(self.queue, out, out_buf)
        return out.astype(np.float64).reshape(shape)

    def stack_colour(self, eta1, cos_theta, thickness_nm, node_indices, rule):
        """RGB (P, 3) of one film stack at points (cos θ1, d), by ``rule`` with the film's and base's
        indices per node (``node_indices`` = (η2, η3, κ3), each (N,): dispersive materials): the
        kernel's reflectance summed on the device, its Fresnel side once per distinct cos θ1 × node."""
        import pyopencl as cl

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
        terms = cl.Buffer(self.ctx, mf.READ_WRITE, cos_values.size * rule.count * _STACK_TERMS * np.dtype(real).itemsize)
        self._run(self.stack_terms_kernel, cos_values.size * rule.count, cos1, cos2_hi, eta2_buf, buffer(eta3),
                  buffer(kappa3), real(eta1), real(thickness_nm.max()), np.int32(rule.count), terms)
        n_blocks = -(-rule.count // _STACK_BLOCK)
        out = np.empty((n_blocks, cos_index.size, 3), self.dtype)
        out_buf = cl.Buffer(self.ctx, mf.WRITE_ONLY, out.nbytes)
        self._run(self.stack_kernel, out.size // 3, cos1, cos2_hi, cos2_lo, terms, buffer(cos_index, np.int32),
                  *(buffer(a) for a in _split(thickness_nm, self.dtype)), eta2_buf,
                  *(buffer(a) for a in _split(1.0 / rule.wavelength_nm, self.dtype)), buffer(rule.weights),
                  np.int32(rule.count), np.int32(_STACK_BLOCK), np.int32(cos_index.size), out_buf)
        cl.enqueue_copy(self.queue, out, out_buf)
        return out.astype(np.float64).sum(axis=0)


def backend(name: str = "auto", compute: str = "float64", integrator: str = "series", device=None):
    """The integrator for ``name`` ('opencl', 'numpy' or 'auto': OpenCL, else numpy with a warning);
    ``integrator`` picks the OpenCL kernel ('series' or 'direct', see OpenCLBackend), ``device``
    the OpenCL device (``find_device``)."""
    if name == "numpy":
        return NumpyBackend()
    try:
        return OpenCLBackend(compute, integrator, device)
    except (OpenCLUnavailable, ImportError) as exc:
        if name == "opencl":
            raise
        warnings.warn(f"OpenCL unavailable ({exc}); baking with the numpy path, which is much slower",
                      RuntimeWarning, stacklevel=2)
        return NumpyBackend()


def survey_devices(throughput_spec=None) -> list:
    """Every OpenCL device: whether the kernel builds (float64, float32), passes the self-check,
    and, given a spec, its measured cells per second baking it (after a warm-up band)."""
    import time

    try:
        devices = opencl_devices()
    except (OpenCLUnavailable, ImportError) as exc:
        return [{"index": None, "key": "opencl", "label": "no OpenCL platform", "error": str(exc)}]
    default = _default_device_key()
    rows = []
    for index, device in enumerate(devices):
        row = {"index": index, "key": device_key(device), "label": device_label(device),
               "default": device_key(device) == default}
        for compute in ("float64", "float32"):
            try:
                fast = OpenCLBackend(compute, device=str(index))
                row[compute] = {"builds": True, "self_check_error": self_check_error(fast)}
            except OpenCLUnavailable as exc:
                row[compute] = {"builds": False, "error": str(exc)}
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
