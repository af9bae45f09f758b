"""OpenCL devices: every registered runtime's devices, each named by its runtime and where that came from,
the order lutbake tries them in, and the devices a selector names (docs/devices.md).

Three sources of runtimes on Linux:

* PoCL from PyPI (``pocl-binary-distribution``) lies in pyopencl's ``.libs`` folder. The ICD loader
  in pyopencl's wheel (ocl-icd, patched) loads every ``.icd`` there after the vendor folder, whatever
  the environment says: pyopencl points ``PYOPENCL_HOME`` at itself when it is imported.
* The system's runtimes: the ``.icd`` files of the vendor folder (``OCL_ICD_VENDORS``, else
  ``OPENCL_VENDOR_PATH``, else /etc/OpenCL/vendors), e.g. Debian's ``pocl-opencl-icd``.
* Intel's CPU runtime from PyPI (``opencl-rt``, the ``cpu`` extra) lies in the environment's lib/
  and registers itself nowhere: the user registers it (lutbake/integrate/icd.py).

The device is an argument: ``candidate_devices`` turns what a caller passes (a selector, a pyopencl
Device, or None for the default rule) into the devices to try. Nothing here reads or writes the
environment; the command line resolves ``--device``, ``LUTBAKE_DEVICE`` and ``PYOPENCL_CTX``.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

from lutbake.errors import OpenCLUnavailable
from lutbake.io.signals import stop_signals_held

if TYPE_CHECKING:
    from typing import TypeAlias

    import pyopencl

    # What a caller passes as ``device``: a selector, a pyopencl Device, or None for the default rule.
    DeviceChoice: TypeAlias = str | pyopencl.Device | None

__all__ = [
    "Runtime",
    "runtime_of",
    "opencl_devices",
    "device_key",
    "device_label",
    "find_devices",
    "PyopenclCtx",
    "find_device",
    "candidate_devices",
]

FAMILIES = {"Portable Computing Language": ("pocl", "PoCL"), "Intel(R) OpenCL": ("intel", "Intel OpenCL")}


@functools.cache
def import_pyopencl() -> ModuleType:
    """pyopencl, imported once with SIGINT and SIGTERM held (signals.stop_signals_held): its C++ extension
    builds Python enums while it initialises, and an exception that a stop signal's handler raises there
    cannot unwind through C++ (std::terminate: the process aborts where it should exit 130). Held, the
    signal arrives once the module is loaded."""
    with stop_signals_held():
        import pyopencl
    return pyopencl


@dataclass(frozen=True)
class Runtime:
    """An OpenCL platform's runtime: its family ('pocl', 'intel', …), where it came from ('PyPI': its
    library lies in this Python environment; 'system': elsewhere, e.g. a distribution's package),
    its version and, for PoCL, the LLVM it compiles with."""

    family: str
    name: str
    origin: str
    version: str
    llvm: str = ""

    def __str__(self) -> str:
        """'PoCL 3.1+debian (system, LLVM 15.0.6)'."""
        return f"{self.name} {self.version} ({self.origin}{f', LLVM {self.llvm}' if self.llvm else ''})"


class _DlInfo(ctypes.Structure):
    _fields_ = [
        ("dli_fname", ctypes.c_char_p),
        ("dli_fbase", ctypes.c_void_p),
        ("dli_sname", ctypes.c_char_p),
        ("dli_saddr", ctypes.c_void_p),
    ]


def _library_of(platform: pyopencl.Platform) -> Path | None:
    """The shared library that serves ``platform``, or None where that cannot be told. An ICD
    platform (cl_khr_icd) begins with its dispatch table, whose second entry is the runtime's own
    clGetPlatformInfo (Khronos cl_icd.h); dladdr names the file that holds that function."""
    if "cl_khr_icd" not in platform.extensions:
        return None
    try:
        dladdr = ctypes.CDLL(None).dladdr
    except (OSError, AttributeError):  # no dladdr in this C library
        return None
    dladdr.argtypes = [ctypes.c_void_p, ctypes.POINTER(_DlInfo)]
    table = ctypes.c_void_p.from_address(platform.int_ptr).value
    function = table and ctypes.c_void_p.from_address(table + ctypes.sizeof(ctypes.c_void_p)).value
    info = _DlInfo()
    if not function or not dladdr(function, ctypes.byref(info)) or not info.dli_fname:
        return None
    return Path(os.fsdecode(info.dli_fname)).resolve()


def _origin(library: Path | None) -> str:
    """'PyPI' for a library inside this Python environment or pyopencl's folder (what pip installed:
    PoCL in pyopencl's .libs, Intel's opencl-rt in lib/), else 'system'."""
    homes = [Path(sys.prefix).resolve(), Path(import_pyopencl().__path__[0]).resolve()]
    return "PyPI" if library and any(library.is_relative_to(home) for home in homes) else "system"


_RUNTIMES: dict[int, Runtime] = {}


def runtime_of(device: pyopencl.Device) -> Runtime:
    """The runtime of ``device``'s platform (read once per platform and process)."""
    platform = device.platform
    if platform.int_ptr not in _RUNTIMES:
        name, version = platform.name.strip(), platform.version.strip()
        family, title = FAMILIES.get(name, (name.split()[0].lower() if name else "opencl", name))
        pocl = re.search(r"PoCL (\S+)", version)  # 'OpenCL 3.0 PoCL 3.1+debian  Linux, …, LLVM 15.0.6, …'
        llvm = re.search(r"LLVM (\d[\w.]*)", version)
        _RUNTIMES[platform.int_ptr] = Runtime(
            family,
            title,
            _origin(_library_of(platform)),
            pocl[1] if pocl else device.driver_version.strip() or version,
            llvm[1] if llvm and family == "pocl" else "",
        )
    return _RUNTIMES[platform.int_ptr]


# The order lutbake tries devices in (docs/devices.md, measured there): PoCL first, the system's before
# PyPI's (a distribution builds PoCL with its current LLVM and picks the target CPU from the CPU's
# features, so it compiles where PyPI's PoCL 3.0, LLVM 14, cannot name the CPU), then every other
# runtime in the loader's order.
def _preference(device: pyopencl.Device) -> tuple[bool, bool]:
    runtime = runtime_of(device)
    return runtime.family != "pocl", runtime.origin != "system"


def opencl_devices() -> list[pyopencl.Device]:
    """Every OpenCL device of every registered runtime, in the order lutbake tries them (``_preference``)."""
    cl = import_pyopencl()
    try:
        platforms = cl.get_platforms()
    except cl.Error as exc:
        raise OpenCLUnavailable(f"no OpenCL platform: {exc}") from None
    devices: list[pyopencl.Device] = []
    for platform in platforms:
        with contextlib.suppress(cl.Error):  # a platform offering no device (PoCL with POCL_DEVICES=none)
            devices += platform.get_devices()
    return sorted(devices, key=_preference)


def device_key(device: pyopencl.Device, devices: list[pyopencl.Device] | None = None) -> str:
    """Short stable name of a device: its runtime's family and origin ('pocl-system', 'pocl-pypi',
    'intel-pypi'), plus ':N' for the N-th further device of that name."""
    key = _runtime_key(device)
    same = [d for d in (devices or opencl_devices()) if _runtime_key(d) == key]
    index = same.index(device) if device in same else 0
    return key if index == 0 else f"{key}:{index}"


def _runtime_key(device: pyopencl.Device) -> str:
    runtime = runtime_of(device)
    return f"{runtime.family}-{runtime.origin.lower()}"


def device_label(device: pyopencl.Device) -> str:
    """'runtime / device', e.g. 'PoCL 3.1+debian (system, LLVM 15.0.6) / pthread-skylake-avx512-AMD EPYC'."""
    return f"{runtime_of(device)} / {device.name.strip()}"


PYOPENCL_CTX = "PYOPENCL_CTX"  # the origin of a selector in pyopencl's own syntax


def find_devices(selector: str, origin: str = "device") -> list[pyopencl.Device]:
    """The devices a selector names, in the order lutbake tries them. ``origin`` says whose selector it is:

    * 'device' (``--device``, ``LUTBAKE_DEVICE``, a caller's ``device=``): its index in
      ``opencl_devices()``, its key ('pocl-system'), a runtime family ('pocl': every PoCL, 'intel'), or
      a case-insensitive part of its label naming one device;
    * ``PYOPENCL_CTX``: pyopencl's platform[:device] (indices or parts of names, in the loader's platform
      order), naming one device.

    A selector naming none (or, but for a family, more than one) is a ValueError listing the devices.
    """
    if origin == PYOPENCL_CTX:
        return [_pyopencl_ctx_device(selector)]
    devices = opencl_devices()
    text = str(selector).strip().lower()
    if text.isdigit() and int(text) < len(devices):
        return [devices[int(text)]]
    exact = [d for d in devices if device_key(d, devices) == text]
    family = [d for d in devices if runtime_of(d).family == text]
    found = exact or family or [d for d in devices if text in device_label(d).lower()]
    if not found or len(found) > 1 and not family:
        known = ", ".join(f"{i} ({device_key(d, devices)}: {device_label(d)})" for i, d in enumerate(devices))
        state = "matches no" if not found else "matches more than one"
        raise ValueError(f"device {selector!r} {state} OpenCL device; devices: {known or 'none'}")
    return found


def _pyopencl_ctx_device(selector: str) -> pyopencl.Device:
    """The device pyopencl's ``create_some_context`` picks for ``selector`` (PYOPENCL_CTX's syntax), given
    as its answers: pyopencl reads no environment then."""
    cl = import_pyopencl()
    try:
        return cl.create_some_context(interactive=False, answers=str(selector).split(":")).devices[0]
    except (cl.Error, RuntimeError, ValueError) as exc:  # pyopencl's words for a selector it cannot match
        raise ValueError(
            f"{PYOPENCL_CTX}={selector!r} names no OpenCL device ({exc}): "
            "unset it, or give a platform:device index such as 0:0"
        ) from None


def find_device(selector: str, origin: str = "device") -> pyopencl.Device:
    """The first device ``find_devices`` names."""
    return find_devices(selector, origin)[0]


class PyopenclCtx(str):
    """A device selector in pyopencl's PYOPENCL_CTX syntax (platform[:device]): a string a caller passes as
    ``device=`` like any other, read by pyopencl's rules (``find_devices(..., PYOPENCL_CTX)``)."""


def candidate_devices(device: DeviceChoice = None) -> list[pyopencl.Device]:
    """The devices to try, in order, for a caller's ``device``: a pyopencl Device is tried alone, a selector
    string names devices (``find_devices``; a ``PyopenclCtx`` by pyopencl's rules), None or '' leaves every
    device (``opencl_devices`` order)."""
    if device is None or isinstance(device, str) and not device:
        return opencl_devices()
    if isinstance(device, PyopenclCtx):
        return find_devices(device, PYOPENCL_CTX)
    return find_devices(device) if isinstance(device, str) else [device]
