"""Every OpenCL device surveyed (`lutbake devices`): whether the kernel builds in each precision, its
self-check, and its measured throughput."""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, Any

from lutbake.errors import OpenCLUnavailable
from lutbake.integrate.bands import bake_rows_all
from lutbake.integrate.devices import device_key, device_label, opencl_devices, runtime_of
from lutbake.integrate.opencl import OpenCLBackend
from lutbake.integrate.selfcheck import checked_error

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.devices import DeviceChoice

__all__ = ["survey_devices"]


def survey_devices(throughput_spec: BakeSpec | None = None, device: DeviceChoice = None) -> list[dict]:
    """Every OpenCL device: whether the kernel builds (float64, float32), passes the self-check,
    and, given a spec, its measured cells per second baking it (after a warm-up band); ``default`` marks
    the device a bake asking for ``device`` (a selector, or None: the default rule) runs on."""
    try:
        devices = opencl_devices()
        error = "" if devices else "no OpenCL platform offers a device"
    except (OpenCLUnavailable, ImportError) as exc:
        devices, error = [], str(exc)
    if error:
        return [{"index": None, "key": "opencl", "label": "no OpenCL device", "error": error}]
    default = _default_device_key(device)
    rows = []
    for index, device in enumerate(devices):
        key, label = device_key(device, devices), device_label(device)
        row: dict[str, Any] = {  # a JSON object (`lutbake devices --json`)
            "index": index,
            "key": key,
            "label": label,
            "default": key == default,
            "runtime": dataclasses.asdict(runtime_of(device)),
        }
        for compute in ("float64", "float32"):
            try:
                fast = OpenCLBackend(compute, device=device)
                row[compute] = {"builds": True, "self_check_error": checked_error(fast, device)}
            except OpenCLUnavailable as exc:  # one device tried: its reason, without its label
                row[compute] = {"builds": False, "error": str(exc).removeprefix(f"{label}: ")}
        if throughput_spec is not None and row["float64"].get("builds"):
            fast = OpenCLBackend("float64", device=device)
            fast.bake_rows(throughput_spec, 0, 1)
            start = time.perf_counter()
            bake_rows_all(fast, throughput_spec)
            row["cells_per_second"] = throughput_spec.cells / (time.perf_counter() - start)
        rows.append(row)
    return rows


def _default_device_key(device: DeviceChoice = None) -> str | None:
    """Key of the device ``OpenCLBackend(device=device)`` picks, or None."""
    try:
        return device_key(OpenCLBackend("float64", device=device).program.device)
    except (OpenCLUnavailable, ImportError, ValueError):
        return None
