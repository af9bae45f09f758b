"""A bake's bands through the device and into the EXR, and where its time goes.

``stream_bands`` keeps the device busy while the host writes: band k + 1 is enqueued before band k is
waited for and written. The write runs on OpenEXR's own thread pool (lutbake/tables/exr.py), whose
threads compress while the device's threads bake, so a bake on a CPU device keeps every core busy.
``BakeStages`` times each stage of a bake (the integrator's start, the plan, waiting on the device, the
write) and the process's CPU time over each, so how many cores each kept busy and how many core-seconds it
left idle (what running anything beside it could at most fill): `lutbake bake --json`,
bench/bench_b1.py and bench/bench_default_set.py print them.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from lutbake.io.cores import usable_cores

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.bands import Integrator, PendingRows
    from lutbake.tables.exr import ExrRows

__all__ = ["BakeStages", "STAGES", "stream_bands"]

STAGES = ("compile", "plan", "device", "write")  # BakeStages' timed stages; the rest of a bake's wall is "other"

# on_band(rows done in this call, the image's rows): a bake's progress, band by band
OnBand = Callable[[int, int], object]


@dataclass
class BakeStages:
    """Wall seconds of a bake's stages, and the CPU seconds of the whole process (every thread: the
    device's, OpenEXR's pool) over the bake and over each stage.

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
    stage_cpu_s : dict
        CPU time of the process within each stage (STAGES), s: the device's threads and OpenEXR's pool
        count in the stage during which they run.
    """

    compile_s: float = 0.0
    plan_s: float = 0.0
    device_s: float = 0.0
    write_s: float = 0.0
    cpu_s: float = 0.0
    stage_cpu_s: dict[str, float] = field(default_factory=dict)

    @contextlib.contextmanager
    def clock(self, stage: str) -> Iterator[None]:
        """Add the block's wall time to ``stage`` (one of STAGES), and the process's CPU time over it."""
        start, cpu_start = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            name = f"{stage}_s"
            setattr(self, name, getattr(self, name) + time.perf_counter() - start)
            self.stage_cpu_s[stage] = self.stage_cpu_s.get(stage, 0.0) + time.process_time() - cpu_start

    def describe(self, wall_s: float, cores: int | None = None) -> dict:
        """The stages' walls, the rest of ``wall_s`` (``other_s``: the metadata, the host's share of the
        bands), ``cpu_s`` and ``cpu_per_wall``; per stage (other included) the CPU seconds
        (``stage_cpu_s``), the cores busy (``stage_cores``: CPU over wall) and the core-seconds left idle
        on ``cores`` (None: the cores this process may run on; ``idle_core_s``, and in all
        ``idle_core_s_total``: the most that running other work beside the stage could fill)."""
        walls = {stage: getattr(self, f"{stage}_s") for stage in STAGES}
        walls["other"] = max(0.0, wall_s - sum(walls.values()))
        cpu = {stage: self.stage_cpu_s.get(stage, 0.0) for stage in STAGES}
        cpu["other"] = max(0.0, self.cpu_s - sum(cpu.values()))
        cores = usable_cores() if cores is None else cores
        idle = {stage: max(0.0, cores * walls[stage] - cpu[stage]) for stage in walls}
        return {
            **{f"{stage}_s": wall for stage, wall in walls.items()},
            "cpu_s": self.cpu_s,
            "cpu_per_wall": self.cpu_s / max(wall_s, 1e-12),
            "stage_cpu_s": cpu,
            "stage_cores": {stage: cpu[stage] / wall if wall > 0 else 0.0 for stage, wall in walls.items()},
            "cores": cores,
            "idle_core_s": idle,
            "idle_core_s_total": sum(idle.values()),
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
