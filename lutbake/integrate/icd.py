"""Registering Intel's CPU runtime from PyPI with the OpenCL ICD loader: a vendor folder to point
``OCL_ICD_VENDORS`` at (docs/devices.md).

The loader (ocl-icd, bundled by pyopencl) reads one vendor folder, which only the environment names
(``OCL_ICD_VENDORS``, else ``OPENCL_VENDOR_PATH``, else /etc/OpenCL/vendors), once per process, at its
first platform query. Intel's runtime (``opencl-rt``, the ``cpu`` extra) lies in the environment's lib/
and registers itself nowhere, and lutbake changes no environment. So ``write_vendor_folder`` writes a
folder holding a link to each ``.icd`` of the system's folder and one ``.icd`` naming Intel's library;
the user exports it (``lutbake devices --icd-folder`` writes it into the user cache and prints its path),
and a test process sets it before pyopencl loads (tests/conftest.py). No file or variable here is read
before pyopencl: importing this module loads nothing of OpenCL.
"""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pyopencl

__all__ = [
    "SYSTEM_VENDORS",
    "INTEL_ICD",
    "environment_intel_library",
    "write_vendor_folder",
    "intel_vendor_folder",
    "unregistered_intel",
]

SYSTEM_VENDORS = Path("/etc/OpenCL/vendors")  # the loaders' vendor folder when no variable names one
INTEL_ICD = "lutbake-environment-intel-cpu.icd"  # the entry naming Intel's library in a folder written here
VENDOR_FOLDER = "opencl-vendors"  # intel_vendor_folder's, in the user cache


def environment_intel_library(prefix: str = sys.prefix) -> Path | None:
    """Intel's CPU runtime in the Python environment at ``prefix`` (lib/libintelocl.so), or None."""
    library = Path(prefix) / "lib" / "libintelocl.so"
    return library if library.is_file() else None


def write_vendor_folder(
    folder: str | PathLike[str],
    intel_library: str | PathLike[str],
    system_vendors: str | PathLike[str] = SYSTEM_VENDORS,
) -> Path:
    """Make ``folder`` (created if need be) a vendor folder holding a link to each ``.icd`` of
    ``system_vendors`` and ``INTEL_ICD`` naming ``intel_library``; return it. Writing again brings it up
    to date: each entry is replaced atomically (a loader reading meanwhile sees the old one or the new),
    and an ``.icd`` the system's folder no longer holds is removed."""
    folder, system_vendors = Path(folder), Path(system_vendors)
    if system_vendors.is_dir() and folder.exists() and folder.resolve() == system_vendors.resolve():
        raise ValueError(f"vendor folder {str(folder)!r} is the system's own ({system_vendors}): name another")
    folder.mkdir(parents=True, exist_ok=True)
    system = sorted(system_vendors.glob("*.icd")) if system_vendors.is_dir() else []
    entries = {icd.name: icd for icd in system if icd.name != INTEL_ICD}
    for name, icd in entries.items():
        _replace(folder / name, functools.partial(os.symlink, icd.absolute()))  # make(tmp): tmp -> icd
    _replace(folder / INTEL_ICD, lambda tmp: tmp.write_text(f"{Path(intel_library).resolve()}\n"))
    for stale in folder.glob("*.icd"):
        if stale.name not in entries and stale.name != INTEL_ICD:
            stale.unlink()
    return folder


def intel_vendor_folder(
    cache_folder: str | PathLike[str], system_vendors: str | PathLike[str] = SYSTEM_VENDORS
) -> Path:
    """The vendor folder registering this environment's Intel runtime beside ``system_vendors``' runtimes,
    written (or brought up to date) as ``cache_folder``/opencl-vendors; a ValueError where the runtime is
    not installed."""
    library = environment_intel_library()
    if library is None:
        raise ValueError("Intel's OpenCL CPU runtime is not installed in this Python environment (lutbake's cpu extra)")
    return write_vendor_folder(Path(cache_folder) / VENDOR_FOLDER, library, system_vendors)


def _replace(path: Path, make: Callable[[Path], object]) -> None:
    """``make(tmp)`` writes a temporary beside ``path``, which then takes ``path``'s place in one rename."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.unlink(missing_ok=True)
    try:
        make(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def unregistered_intel(devices: list[pyopencl.Device] | None = None) -> Path | None:
    """Intel's library in this environment when none of ``devices`` (default: every listed device,
    ``devices.opencl_devices()``) runs on it, i.e. it is installed but not registered; else None."""
    from lutbake.errors import OpenCLUnavailable
    from lutbake.integrate.devices import opencl_devices, runtime_of

    library = environment_intel_library()
    if library is None:
        return None
    if devices is None:
        try:
            devices = opencl_devices()
        except (OpenCLUnavailable, ImportError):
            devices = []
    registered = any((runtime_of(d).family, runtime_of(d).origin) == ("intel", "PyPI") for d in devices)
    return None if registered else library
