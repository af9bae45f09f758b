"""A bake's bands through the device and into the EXR, and where its time goes.

``stream_bands`` keeps the device busy while the host writes: band k + 1 is enqueued before band k is
waited for and written. The write runs on OpenEXR's own thread pool (lutbake/tables/exr.py), whose
threads compress while the device's threads bake, so a bake on a CPU device keeps every core busy.
``BakeStages`` times each stage of a bake (the integrator's start, the plan, waiting on the device, the
write) and the process's CPU time over it: `lutbake bake --json` and bench/bench_b1.py print them.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.bands import Integrator, PendingRows
    from lutbake.tables.exr import ExrRows

__all__ = ["BakeStages", "stream_bands"]

# on_band(rows done in this call, the image's rows): a bake's progress, band by band
OnBand = Callable[[int, int], object]


@dataclass
class BakeStages:
    """Wall seconds of a bake's stages, and the CPU seconds of the whole process (every thread: the
    device's, OpenEXR's pool) over the bake.

    Attributes
    ----------
    compile_s : float
        The integrator up: the kernel built (or found in the runtime's cache) and its self-check.
    plan_s : float
        The series plan on the device, the probes' ground truth beside it, the capped texels' error.
    device_s : float
        Waiting for bands the device had not finished when the host asked for them.
    write_s : float
        Compressing and writing the EXR, and its companions (sidecar, includes).
    cpu_s : float
        CPU time of the process over the bake, s (``cpu_per_wall`` of ``describe``: how many cores were busy).
    """

    compile_s: float = 0.0
    plan_s: float = 0.0
    device_s: float = 0.0
    write_s: float = 0.0
    cpu_s: float = 0.0

    @contextlib.contextmanager
    def clock(self, stage: str) -> Iterator[None]:
        """Add the block's wall time to ``stage`` ('compile', 'plan', 'device' or 'write')."""
        start = time.perf_counter()
        try:
            yield
        finally:
            name = f"{stage}_s"
            setattr(self, name, getattr(self, name) + time.perf_counter() - start)

    def describe(self, wall_s: float) -> dict[str, float]:
        """The stages, the rest of ``wall_s`` (``other_s``: the metadata, the host's share of the bands) and
        ``cpu_per_wall``."""
        stages = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "cpu_s"}
        return {
            **stages,
            "other_s": max(0.0, wall_s - sum(stages.values())),
            "cpu_s": self.cpu_s,
            "cpu_per_wall": self.cpu_s / max(wall_s, 1e-12),
        }


def stream_bands(
    fast: Integrator,
    spec: BakeSpec,
    exr: ExrRows,
    chunks: Sequence[tuple[int, int]],
    stages: BakeStages,
    on_band: OnBand | None = None,
) -> None:
    """Bake ``spec``'s row ``chunks`` on ``fast`` into ``exr``: band k is written while the device bakes
    band k + 1 (two bands in flight: lutbake/grid/memory.py). Where the file's tiles run in another order
    than the integrators' (``spec.file_layout``), the bands are held as stored and re-tiled at the end."""
    height = spec.image_size[1]
    retiled = spec.file_layout != spec.layout
    held = []  # the bands, as stored, when the file is re-tiled
    pending: PendingRows | None = None
    for band in [*chunks, None]:
        started = fast.begin_rows(spec, *band) if band else None
        if pending is not None:
            with stages.clock("device"):
                rows = pending.result()
            with stages.clock("write"):
                if retiled:
                    held.append(rows.astype(exr.dtype))
                else:
                    exr.write_rows(rows)
            if on_band:
                on_band(rows.shape[0], height)
        pending = started
    if retiled:
        with stages.clock("write"):
            exr.write_rows(spec.file_layout.retile(np.concatenate(held), spec.layout))
