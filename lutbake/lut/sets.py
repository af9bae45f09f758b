"""LUT bakes as `lutbake bake` runs them: the default set's jobs, bakes in bands with a progress line per
LUT, and the summary each bake reports.

A bake here is one file set (lutbake/io/fileset.py: every LUT committed or none), integrated in bands of
at most 1/32 of the image (so the first progress line lands within seconds and the ETA settles early);
the default set goes into a folder made for it, removed again when the bake fails before writing into it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Sequence
from dataclasses import replace
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lutbake.errors import ParameterError
from lutbake.grid.memory import DEFAULT_MEMORY_LIMIT_GIB
from lutbake.grid.spec import BakeSpec
from lutbake.io.progress import meter
from lutbake.lut.bake import BakeResult, bake_set, default_specs

if TYPE_CHECKING:
    from lutbake.integrate.devices import DeviceChoice

__all__ = ["DEFAULT_SET_NAME", "bake_default_set", "bake_luts", "default_set_jobs", "summary", "totals"]

DEFAULT_SET_NAME = "lutbake-default-set"  # the default set's name in its commit journal
_PROGRESS_BANDS = 32  # bands per bake: the first lands within ~2 s and the ETA settles early


def default_set_jobs(
    folder: str | PathLike[str],
    precision: str | None = None,
    **settings: Any,  # BakeSpec's fields, each of its own type
) -> list[tuple[Path, BakeSpec]]:
    """(path, spec) of each LUT of the default set in ``folder``: ``default_specs(precision)`` (None: 'half')
    with ``settings`` (eta1, space, observer, interpolation, compute, method, samples_per_cycle; None
    keeps a spec's own) replaced in every spec.

    >>> jobs = default_set_jobs("luts", space="p3")
    >>> len(jobs), str(jobs[0][0]), jobs[0][1].space, jobs[0][1].precision
    (6, 'luts/lutbake-eta2-1.33.exr', 'p3', 'half')
    """
    settings = {k: v for k, v in settings.items() if v is not None}
    return [
        (Path(folder) / f"{name}.exr", replace(spec, **settings))
        for name, spec in default_specs(precision or "half").items()
    ]


def bake_default_set(
    folder: str | PathLike[str],
    precision: str | None = None,
    backend: str = "auto",
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    device: DeviceChoice = None,
    show_progress: bool | None = False,
    **settings: Any,  # BakeSpec's fields, each of its own type
) -> list[BakeResult]:
    """Bake the default set into ``folder`` (made if missing) as one file set, `lutbake bake` without
    --eta2: ``default_set_jobs(folder, precision, **settings)``, every LUT's memory budget checked before the
    folder is made, then ``bake_luts``. ParameterError for a ``folder`` named like one .exr, or that cannot
    be made. Returns the BakeResults in the set's order."""
    folder = Path(folder)
    if folder.suffix.lower() == ".exr":
        raise ParameterError(
            "{out_dir} {folder}: the default set goes into a folder, not one .exr", folder=repr(str(folder))
        )
    jobs = default_set_jobs(folder, precision, **settings)
    for _, spec in jobs:
        spec.check_budget(memory_limit_gib)
    with _made_for_the_set(folder):  # bake_set checks every member's path before any work
        return bake_luts(jobs, DEFAULT_SET_NAME, backend, memory_limit_gib, device, show_progress)


def bake_luts(
    jobs: Sequence[tuple[Path, BakeSpec]],
    set_name: str,
    backend: str = "auto",
    memory_limit_gib: float = DEFAULT_MEMORY_LIMIT_GIB,
    device: DeviceChoice = None,
    show_progress: bool | None = False,
) -> list[BakeResult]:
    """Bake (path, BakeSpec) ``jobs`` (one folder) as one file set named ``set_name`` (``bake_set``), each in
    bands of at most 1/32 of its image. ``show_progress``: a line per LUT on stderr with the rows done and
    the ETA from the measured rate (True; None: on a terminal only; False: none). Returns the BakeResults."""
    return bake_set(
        [(path, spec, _banded(path, spec, show_progress)) for path, spec in jobs],
        set_name,
        backend,
        memory_limit_gib,
        device=device,
    )


def summary(result: BakeResult) -> dict:
    """The row `bake --json` prints for one LUT."""
    return {
        "path": str(result.path),
        "cells": result.cells,
        "seconds": result.seconds,
        "cells_per_second": result.cells_per_second,
        "backend": result.backend,
        "device": result.device,
        "spectral_error_rgb_max": result.spectral_error_rgb_max,
        "capped_texels": result.capped_texels,
        "truncation_bound": result.truncation_bound,
        "capped_error_rgb_max": result.capped_error_rgb_max,
        "stages": result.stages.describe(result.seconds),
    }


def totals(results: Sequence[BakeResult]) -> dict:
    """The set's row `bake --json` prints beside its LUTs': their cells, walls and CPU summed, and per stage
    (compile, plan, device, write, other) the wall, the CPU, the cores busy (CPU over wall) and the
    core-seconds left idle (lutbake/lut/pipeline.py), so the stage that holds the set back shows."""
    described = [r.stages.describe(r.seconds) for r in results]
    seconds, cpu = sum(r.seconds for r in results), sum(d["cpu_s"] for d in described)
    phases = list(described[0]["stage_cpu_s"]) if described else []
    walls = {phase: sum(d[f"{phase}_s"] for d in described) for phase in phases}
    stage_cpu = {phase: sum(d["stage_cpu_s"][phase] for d in described) for phase in phases}
    idle = {phase: sum(d["idle_core_s"][phase] for d in described) for phase in phases}
    return {
        "cells": sum(r.cells for r in results),
        "seconds": seconds,
        "cpu_s": cpu,
        "cpu_per_wall": cpu / max(seconds, 1e-12),
        "stage_s": walls,
        "stage_cpu_s": stage_cpu,
        "stage_cores": {phase: stage_cpu[phase] / wall if wall > 0 else 0.0 for phase, wall in walls.items()},
        "idle_core_s": idle,
        "idle_core_s_total": sum(idle.values()),
    }


def _banded(path: Path, spec: BakeSpec, show_progress: bool | None) -> dict:
    """``bake``'s on_band and chunk_cells for a bake in progress bands, its meter started with the LUT's bake."""
    width, height = spec.image_size
    rows_per_band = min(spec.row_chunks()[0][1], -(-height // _PROGRESS_BANDS))  # never above the memory bound
    line, done = None, 0

    def on_band(rows: int, total: int) -> None:  # called with 0 rows when this LUT's bake starts: its clock starts then
        nonlocal line, done
        line = line or meter(f"baking {path.name}", show_progress)
        done += rows
        line(done, total, "rows" if done else "measuring the spectral rule's error at probe cells")
        if done == total:
            line.close()

    return {"on_band": on_band, "chunk_cells": rows_per_band * width}


@contextlib.contextmanager
def _made_for_the_set(folder: Path) -> Iterator[None]:
    """``folder``, made if missing, and removed again if it is still empty when the block fails (a device
    that cannot run, an interrupt): a failed bake leaves nothing behind."""
    made = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(
            "{out_dir} folder {folder} cannot be created: {why}", folder=repr(str(folder)), why=exc.strerror
        ) from None
    try:
        yield
    except BaseException:
        if made:
            with contextlib.suppress(OSError):
                folder.rmdir()
        raise
