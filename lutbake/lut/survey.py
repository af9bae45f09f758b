"""The device survey `lutbake devices` prints: every OpenCL device, whether it builds the kernel and passes
its self-check, and its rate baking one probe grid (lutbake/integrate/opencl.py ``survey_devices``).

The probe is a small LUT of a glass-like film over dielectric and metal bases (32 × 128 × 4 × 4 cells,
D to 3000 nm): large enough that launch overheads do not dominate, small enough to time in a second.
"""

from __future__ import annotations

from lutbake.grid.spec import Axis, BakeSpec

__all__ = ["THROUGHPUT_PROBE", "survey"]

THROUGHPUT_PROBE = BakeSpec(
    eta2=1.5,
    axes=(
        Axis("cos_theta", 0.0, 1.0, 32, "sqrt"),
        Axis("opd_nm", 0.0, 3000.0, 128),
        Axis("eta3", 1.0, 3.0, 4),
        Axis("kappa3", 0.0, 5.0, 4, "sqrt"),
    ),
)


def survey() -> dict:
    """The document `devices --json` prints: the probe's cell count and one row per device (``survey_devices``
    with ``THROUGHPUT_PROBE``)."""
    from lutbake.integrate.opencl import survey_devices

    return {"throughput_cells": THROUGHPUT_PROBE.cells, "devices": survey_devices(THROUGHPUT_PROBE)}
