"""The OpenCL integrator, and the choice of integrator (``backend``).

``OpenCLBackend`` runs kernels/*.cl through pyopencl on the device its ``device`` argument names (a
selector, a pyopencl Device), by default on the first device in lutbake/integrate/devices.py's order
(PoCL, the system's before PyPI's, then every other runtime) that builds the kernel
(lutbake/integrate/program.py) and passes its self-check (lutbake/integrate/selfcheck.py); a GPU's
driver runs the same source unchanged. It bakes a band of rows by the series and the poles' closed form
(lutbake/integrate/series.py), with the direct quadrature for what they leave
(lutbake/integrate/direct.py), and evaluates given points (lutbake/integrate/pointwise.py). Every
integrator returns the RGB of every texel of a band of image rows, an array (rows, width, 3); the numpy
path (lutbake/integrate/numpy_path.py) is the reference and the fallback.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.errors import OpenCLUnavailable, ParameterError
from lutbake.integrate.bands import PendingRows, colours_by_level, with_grazing_white
from lutbake.integrate.devices import candidate_devices, device_label
from lutbake.integrate.direct import DirectOnDevice
from lutbake.integrate.numpy_path import NumpyBackend
from lutbake.integrate.pointwise import kernel_reflectance, kernel_stack_colour
from lutbake.integrate.program import device_program
from lutbake.integrate.selfcheck import SELF_CHECK_TOLERANCE, checked_error
from lutbake.integrate.series import SeriesOnDevice, SeriesStats
from lutbake.physics.points import FilmPoints

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.devices import DeviceChoice
    from lutbake.spectral.rules import SpectralRule

__all__ = ["OpenCLBackend", "DeviceCannotRun", "backend"]


class OpenCLBackend:
    """kernels/*.cl on an OpenCL device: the first that builds the kernel and passes its self-check among
    those ``device`` names (``devices.candidate_devices``: a pyopencl Device; a selector naming one device
    or a family such as 'pocl'; None: every device, in ``devices.opencl_devices`` order).

    ``integrator`` 'series' (the bake's default) runs the Fourier series where
    its rule allows, the poles' closed form (kernels/poles.cl) where the film
    propagates and the series would be long, and the direct quadrature for
    what is left (evanescent films, films whose poles are too many); 'direct'
    runs the quadrature on every texel.
    """

    name = "opencl"

    def __init__(self, compute: str = "float64", integrator: str = "series", device: DeviceChoice = None):
        self.compute = compute
        self.integrator = integrator
        self.dtype = np.float64 if compute == "float64" else np.float32
        reasons = []
        for candidate in candidate_devices(device):
            # a spec's buffers belong to one context
            self._series: SeriesOnDevice | None = None
            self._direct: DirectOnDevice | None = None
            built = device_program(candidate, compute)
            if isinstance(built, OpenCLUnavailable):
                reasons.append(str(built))
                continue
            self.program, self.ctx, self.queue = built, built.ctx, built.queue
            error = checked_error(self, candidate)
            if error <= SELF_CHECK_TOLERANCE[compute]:
                return
            reasons.append(
                f"{device_label(candidate)}: fails the self-check (|ΔR| {error:.2g} against numpy, "
                f"tolerance {SELF_CHECK_TOLERANCE[compute]:g})"
            )
        raise OpenCLUnavailable("; ".join(reasons) or "no OpenCL device found")

    @property
    def device(self) -> str:
        """The device that runs the kernel, as 'platform / device'."""
        return device_label(self.program.device)

    def _series_of(self, spec: BakeSpec) -> SeriesOnDevice:
        """The series' buffers and plan for ``spec`` (made once per spec)."""
        if self._series is None or self._series.spec.content_hash != spec.content_hash:
            self._series = SeriesOnDevice(self.program, spec)
        return self._series

    def _direct_of(self, spec: BakeSpec) -> DirectOnDevice:
        """The direct quadrature's buffers for ``spec`` (made once per spec)."""
        if self._direct is None or self._direct.spec.content_hash != spec.content_hash:
            self._direct = DirectOnDevice(self.program, spec)
        return self._direct

    def series_plan(self, spec: BakeSpec) -> SeriesStats:
        """The rule's outcome over the whole grid (plan_rows; plan_texels_closed, which keeps its colours)."""
        if self.integrator == "direct":
            return NumpyBackend.series_plan(spec)
        return self._series_of(spec).plan().stats

    def bake_rows(self, spec: BakeSpec, y0: int, y1: int) -> np.ndarray:
        return self.begin_rows(spec, y0, y1).result()

    def begin_rows(self, spec: BakeSpec, y0: int, y1: int) -> PendingRows:
        """Enqueue the band [y0, y1) and return at once (unless some of its texels take the direct
        quadrature, whose rule levels the host computes): the caller writes the previous band while the
        device works."""
        width, _ = spec.image_size
        out = np.empty((y1 - y0, width, 3), self.dtype)
        out_buf = self.program.scratch(out.nbytes)
        keep: list[object] = [out_buf]
        texels: np.ndarray | None  # the band's texels left for the direct quadrature, if any
        if self.integrator == "direct":
            texels, levels = np.arange((y1 - y0) * width, dtype=np.int32), spec.row_levels(y0, y1)
        else:
            passes, texels = self._series_of(spec).enqueue_band(y0, y1, out_buf)
            keep += passes
            if texels is not None:
                levels = spec.cell_levels(*(np.ravel(p)[texels] for p in spec.cell_params(y0, y1)))
        if texels is not None:
            keep += self._direct_of(spec).enqueue(y0, texels, levels, out_buf)
        copy = self.program.read(out, out_buf, blocking=False)
        return PendingRows(out, copy, keep, lambda rows: with_grazing_white(spec, y0, rows))

    def evaluate(self, spec: BakeSpec, stack: FilmPoints) -> np.ndarray:
        """RGB (P, 3) of P stacks of the spec's film (flat fields): the kernel's R at each one's rule nodes."""
        return colours_by_level(spec, stack, self.reflectance)

    def reflectance(self, stack: FilmPoints, wavelength_nm: npt.ArrayLike) -> np.ndarray:
        """The kernel's unpolarized R of the stacks at ``wavelength_nm`` (pointwise.kernel_reflectance)."""
        return kernel_reflectance(self.program, stack, wavelength_nm)

    def stack_colour(
        self,
        eta1: float,
        cos_theta: npt.ArrayLike,
        thickness_nm: npt.ArrayLike,
        node_indices: tuple[npt.ArrayLike, npt.ArrayLike, npt.ArrayLike],
        rule: SpectralRule,
    ) -> np.ndarray:
        """RGB (P, 3) of one film stack at points (cos θ1, d) by ``rule`` (pointwise.kernel_stack_colour)."""
        return kernel_stack_colour(self.program, eta1, cos_theta, thickness_nm, node_indices, rule)


class DeviceCannotRun(ParameterError, OpenCLUnavailable):
    """The OpenCL device a caller named (``device``) does not build the kernel or fails its self-check:
    bad input (the CLI's exit 2), not a reason to fall back to numpy."""


def backend(
    name: str = "auto", compute: str = "float64", integrator: str = "series", device: DeviceChoice = None
) -> OpenCLBackend | NumpyBackend:
    """The integrator for ``name`` ('opencl', 'numpy' or 'auto': OpenCL, else numpy with a warning);
    ``integrator`` picks the OpenCL kernel ('series' or 'direct', see OpenCLBackend), ``device`` the OpenCL
    device: a selector (``devices.find_devices``), a pyopencl Device, or None for the first that runs the
    kernel (docs/devices.md). A device named here that cannot run raises DeviceCannotRun, even under
    'auto': only the default device falls back."""
    if name == "numpy":
        return NumpyBackend()
    try:
        return OpenCLBackend(compute, integrator, device)
    except (OpenCLUnavailable, ImportError) as exc:
        if device is not None and device != "":  # a device the user named is not swapped behind their back
            raise DeviceCannotRun(
                "{device} {selector} cannot run the kernel ({reason}): name another "
                "(`lutbake devices` lists them) or omit it",
                selector=repr(device if isinstance(device, str) else device_label(device)),
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
