"""The device survey `lutbake devices` prints: every OpenCL device, whether it builds the kernel and passes
its self-check, and its rate baking one probe grid (lutbake/integrate/survey.py ``survey_devices``).

The probe is a small LUT of a glass-like film over dielectric and metal bases (32 × 128 × 4 × 4 cells,
D to 3000 nm): large enough that launch overheads do not dominate, small enough to time in a second.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

from lutbake.grid.spec import Axis, BakeSpec

if TYPE_CHECKING:
    from lutbake.integrate.devices import DeviceChoice

__all__ = ["THROUGHPUT_PROBE", "survey", "vendor_folder"]

THROUGHPUT_PROBE = BakeSpec(
    eta2=1.5,
    axes=(
        Axis("cos_theta", 0.0, 1.0, 32, "sqrt"),
        Axis("opd_nm", 0.0, 3000.0, 128),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 5.0, 4, "sqrt"),
    ),
)


def survey(device: DeviceChoice = None) -> dict:
    """The document `devices --json` prints: the probe's cell count, one row per device (``survey_devices``
    with ``THROUGHPUT_PROBE``; ``default`` marks the one a bake on ``device`` uses) and, where Intel's runtime
    is installed in this environment but not registered with the ICD loader, its library
    (``unregistered_intel``)."""
    from lutbake.integrate.icd import unregistered_intel
    from lutbake.integrate.survey import survey_devices

    unregistered = unregistered_intel()
    return {
        "throughput_cells": THROUGHPUT_PROBE.cells,
        "devices": survey_devices(THROUGHPUT_PROBE, device),
        "unregistered_intel": unregistered and str(unregistered),
    }


def vendor_folder(cache_folder: str | PathLike[str] | None, system_vendors: str | PathLike[str] | None = None) -> Path:
    """The ICD vendor folder registering this environment's Intel runtime beside the system's runtimes,
    written into ``cache_folder`` (lutbake/integrate/icd.py ``intel_vendor_folder``); its path."""
    from lutbake.integrate.icd import SYSTEM_VENDORS, intel_vendor_folder

    if cache_folder is None:
        raise ValueError("no writable cache folder for the vendor folder (set LUTBAKE_CACHE_DIR)")
    return intel_vendor_folder(cache_folder, system_vendors or SYSTEM_VENDORS)
