"""The OpenCL program: kernels/*.cl with the closed form's constants as build options, built once per
device and compute precision, and what a backend launches it through (``DeviceProgram``).

The kernel sources are package resources (lutbake/integrate/kernels/); the constants they share with the
host come from their one statement in lutbake/spectral/poles.py (``kernel_defines``). pyopencl's caches
are used where the user's cache home can be written and turned off where not (``_pyopencl_caches``: a
read-only home builds every time, nothing else changes). ``Kernels`` holds one handle per kernel, named
as the kernel is in kernels/*.cl. The host's inputs follow the kernels' conventions
(``signed_cos_theta2``, ``split_hi_lo``).
"""

from __future__ import annotations

import dataclasses
import functools
import os
import warnings
from importlib import resources
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.errors import OpenCLUnavailable
from lutbake.integrate.devices import device_label, import_pyopencl, runtime_of
from lutbake.physics.optics import normal_admittance

if TYPE_CHECKING:
    import pyopencl
    from pyopencl.typing import KernelArg

__all__ = [
    "KERNEL_SOURCES",
    "Kernels",
    "DeviceProgram",
    "built_program",
    "device_program",
    "kernel_defines",
    "signed_cos_theta2",
    "split_hi_lo",
]

KERNEL_SOURCES = ("kernels/airy.cl", "kernels/poles.cl")
# One work-group size for every launch (global sizes padded to it; the kernels return past their count):
# PoCL builds a kernel's work-group function per distinct local size, which it picks per global size when
# left to choose — ~0.2 s each, and a scene's trials and levels meet dozens of sizes.
LOCAL_SIZE = 64


def kernel_defines() -> list[str]:
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


def _writable_cache(name: str) -> bool:
    """The folder pyopencl (or pytools under it) keeps its cache ``name`` in, in the user's cache home,
    exists or can be made, and this process may write there."""
    import platformdirs

    folder = Path(platformdirs.user_cache_dir(name, name))
    try:
        folder.mkdir(mode=0o755, parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def _pyopencl_caches(cl: ModuleType) -> bool | None:
    """pyopencl's ``cache_dir`` for a build: None (its own folder) where that can be written, else False
    (no binary cache). Its kernels' invoker store (pytools) takes no argument: where that cannot be
    written, its switch is turned off (``_PYOPENCL_NO_CACHE``, where pyopencl keeps PYOPENCL_NO_CACHE;
    read when the first kernel is made): a read-only cache home builds every time, nothing else changes."""
    if not _writable_cache("pytools"):
        cl._PYOPENCL_NO_CACHE = True  # type: ignore[attr-defined]  # pyopencl's private switch: unannotated
    return None if _writable_cache("pyopencl") else False


def _build(device: pyopencl.Device, compute: str) -> tuple[pyopencl.Context, pyopencl.Program]:
    cl = import_pyopencl()
    if compute == "float64" and "cl_khr_fp64" not in device.extensions:
        raise OpenCLUnavailable(f"device {device.name.strip()!r} has no float64: bake with compute float32")
    ctx = cl.Context([device])
    source = "\n".join(resources.files("lutbake.integrate").joinpath(name).read_text() for name in KERNEL_SOURCES)
    options = (["-DLUTBAKE_FP64"] if compute == "float64" else []) + kernel_defines()
    with warnings.catch_warnings():  # pyopencl's note of a non-empty build log
        warnings.simplefilter("ignore")
        try:
            return ctx, cl.Program(ctx, source).build(options=options, cache_dir=_pyopencl_caches(cl))
        except KeyError as exc:  # its cache failed: pyopencl then looks this variable up, unset here
            if exc.args != ("PYOPENCL_CACHE_FAILURE_FATAL",):
                raise
            return ctx, cl.Program(ctx, source).build(options=options, cache_dir=False)


@functools.lru_cache(maxsize=16)
def built_program(
    device: pyopencl.Device, compute: str
) -> tuple[pyopencl.Context, pyopencl.Program] | OpenCLUnavailable:
    """(context, program) built for one device, or the OpenCLUnavailable saying why not."""
    cl = import_pyopencl()
    try:
        return _build(device, compute)
    except (cl.Error, OpenCLUnavailable) as exc:
        return OpenCLUnavailable(f"{device_label(device)}: {why_not_built(device, exc)}")


def why_not_built(device: pyopencl.Device, exc: Exception) -> str:
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


@dataclasses.dataclass(frozen=True)
class Kernels:
    """One handle per kernel of kernels/*.cl, named as the kernel is there."""

    bake_texels_direct: pyopencl.Kernel
    reflectance_points: pyopencl.Kernel
    stack_terms: pyopencl.Kernel
    stack_rgb: pyopencl.Kernel
    pair_transform: pyopencl.Kernel
    bake_rows_series: pyopencl.Kernel
    bake_rows_series_table: pyopencl.Kernel
    plan_rows: pyopencl.Kernel
    max_chunks: pyopencl.Kernel
    plan_texels_closed: pyopencl.Kernel
    bake_texels_closed: pyopencl.Kernel
    scatter_rgb: pyopencl.Kernel

    @classmethod
    def of(cls, program: pyopencl.Program) -> Kernels:
        cl = import_pyopencl()
        return cls(**{field.name: cl.Kernel(program, field.name) for field in dataclasses.fields(cls)})


class DeviceProgram:
    """The program built for one device in one precision: its context, queue and kernels, the colour
    weights' tables uploaded to it (``tables``, by key: every backend on the device shares them, so the
    default set's six bakes upload them once), and the launches and buffers the backends use."""

    def __init__(self, ctx: pyopencl.Context, program: pyopencl.Program, compute: str):
        cl = import_pyopencl()
        self.ctx, self.program, self.compute = ctx, program, compute
        self.device = ctx.devices[0]
        self.dtype = np.float64 if compute == "float64" else np.float32
        self.queue = cl.CommandQueue(ctx)
        self.kernels = Kernels.of(program)
        # (kind, observer, space) -> buffers and scalars passed to kernels as they are
        self.tables: dict[tuple[str, str, str], list] = {}

    def run(self, kernel: pyopencl.Kernel, n_items: int, *args: KernelArg) -> None:
        """``kernel`` over ``n_items`` work-items in work-groups of LOCAL_SIZE (see there), or of the most the
        device allows for that kernel where that is fewer."""
        cl = import_pyopencl()
        local = min(LOCAL_SIZE, kernel.get_work_group_info(cl.kernel_work_group_info.WORK_GROUP_SIZE, self.device))
        kernel(self.queue, (-(-n_items // local) * local,), (local,), *args, np.int32(n_items))

    def input(self, array: npt.ArrayLike, dtype: npt.DTypeLike | None = None) -> pyopencl.Buffer:
        """A read-only buffer holding ``array`` as ``dtype`` (default: the program's real type)."""
        cl = import_pyopencl()
        host = np.ascontiguousarray(array, self.dtype if dtype is None else dtype)
        return cl.Buffer(self.ctx, cl.mem_flags.READ_ONLY | cl.mem_flags.COPY_HOST_PTR, hostbuf=host)

    def scratch(self, nbytes: int, access: str = "rw") -> pyopencl.Buffer:
        """An uninitialised buffer of ``nbytes`` that kernels read and write ('rw'), write ('w') or read
        once the host has copied into it ('r')."""
        cl = import_pyopencl()
        flags = {"rw": cl.mem_flags.READ_WRITE, "w": cl.mem_flags.WRITE_ONLY, "r": cl.mem_flags.READ_ONLY}
        return cl.Buffer(self.ctx, flags[access], nbytes)

    def zeros(self, n: int = 1, dtype: npt.DTypeLike = np.int32) -> pyopencl.Buffer:
        """A buffer of ``n`` zeros the kernels read and write (one: a counter they count into)."""
        cl = import_pyopencl()
        return cl.Buffer(self.ctx, cl.mem_flags.READ_WRITE | cl.mem_flags.COPY_HOST_PTR, hostbuf=np.zeros(n, dtype))

    def read(self, host: np.ndarray, buffer: pyopencl.Buffer, blocking: bool = True) -> pyopencl.Event:
        """Copy ``buffer`` into ``host``; the copy's event."""
        return import_pyopencl().enqueue_copy(self.queue, host, buffer, is_blocking=blocking)

    def write(self, buffer: pyopencl.Buffer, host: np.ndarray, offset_bytes: int = 0) -> None:
        """Copy ``host`` into ``buffer`` from byte ``offset_bytes`` on."""
        import_pyopencl().enqueue_copy(self.queue, buffer, host, device_offset=offset_bytes)

    def count(self, buffer: pyopencl.Buffer) -> int:
        """The int32 a counter buffer holds."""
        count = np.empty(1, np.int32)
        self.read(count, buffer)
        return int(count[0])

    def largest(self, values: pyopencl.Buffer, count: int) -> float:
        """The largest of ``count`` values in a device buffer (max_chunks, then the host)."""
        chunk = 4096
        parts = np.empty(max(1, -(-count // chunk)), self.dtype)
        out = self.scratch(parts.nbytes, "w")
        self.run(self.kernels.max_chunks, parts.size, values, np.int32(count), np.int32(chunk), out)
        self.read(parts, out)
        return float(parts.max())


_DEVICE_PROGRAMS: dict[tuple[int, str], DeviceProgram] = {}


def device_program(device: pyopencl.Device, compute: str) -> DeviceProgram | OpenCLUnavailable:
    """The DeviceProgram of ``built_program(device, compute)``, made once per program, or the
    OpenCLUnavailable saying why the program does not build."""
    built = built_program(device, compute)
    if isinstance(built, OpenCLUnavailable):
        return built
    ctx, program = built
    key = (device.int_ptr, compute)
    if key not in _DEVICE_PROGRAMS or _DEVICE_PROGRAMS[key].program is not program:
        _DEVICE_PROGRAMS[key] = DeviceProgram(ctx, program, compute)
    return _DEVICE_PROGRAMS[key]


def signed_cos_theta2(eta1: npt.ArrayLike, eta2: npt.ArrayLike, cos_theta: npt.ArrayLike) -> np.ndarray:
    """|cos θ2| of the film, negated where the film is evanescent (the kernels' convention)."""
    g2 = normal_admittance(eta2, 0.0, eta1, cos_theta)  # exactly as the numpy path
    return np.where(g2.imag > 0, -g2.imag, g2.real) / eta2


def split_hi_lo(values: npt.ArrayLike, dtype: npt.DTypeLike) -> tuple[np.ndarray, np.ndarray]:
    """(hi, lo) with hi + lo ≈ values to twice the precision of ``dtype`` (the kernels' float-float inputs)."""
    values = np.asarray(values, np.float64)
    hi = values.astype(dtype)
    lo = (values - hi.astype(np.float64)).astype(dtype)
    return np.ascontiguousarray(hi), np.ascontiguousarray(lo)
