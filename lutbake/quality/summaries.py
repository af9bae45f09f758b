"""`lutbake report`'s summary of a LUT or a scene atlas: scored against the ground truth (``report_lut``,
``report_atlas``), gated when a p99 target is given, and written into a folder when one is given (a LUT's
report.html, figures and summary.json; an atlas's summary.json).
"""

from __future__ import annotations

from collections.abc import Callable
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lutbake.io.progress import no_progress
from lutbake.lut.sample import Atlas
from lutbake.quality.report import (
    REPORT_FILES,
    SEARCH_BUDGET,
    SLICE_SEARCH_BUDGET,
    gate,
    report_atlas,
    report_lut,
    write_report,
)

if TYPE_CHECKING:
    from pyopencl import Device

__all__ = ["lut_summary", "atlas_summary"]


def lut_summary(
    path: str | PathLike[str],
    n_points: int = 1000,
    seed: int = 0,
    out_dir: str | PathLike[str] | None = None,
    max_de: float | None = None,
    approximations: bool = True,
    search_budget: int = SEARCH_BUDGET,
    progress: Callable[..., None] = no_progress,
    device: str | Device | None = None,
) -> dict[str, Any]:
    """The LUT at ``path`` scored (``report_lut``: the parameters are its), its summary gated by ``max_de``
    (``gate``) and, given ``out_dir``, written there with the figures and report.html (``write_report``)."""
    rep = report_lut(
        path,
        n_points,
        seed,
        approximations=approximations,
        progress=progress,
        search_budget=search_budget,
        device=device,
    )
    return write_report(rep, out_dir, max_de=max_de, progress=progress) if out_dir else gate(rep.summary(), max_de)


def atlas_summary(
    atlas: Atlas,
    path: str | PathLike[str],
    n_points: int = 1000,
    seed: int = 0,
    out_dir: str | PathLike[str] | None = None,
    max_de: float | None = None,
    search_budget: int = SLICE_SEARCH_BUDGET,
) -> dict[str, Any]:
    """Per-slice ΔE00 of a scene atlas as stored (``report_atlas``: the parameters are its), written to
    ``out_dir``/summary.json when given, then gated by ``max_de`` (the file holds no verdict)."""
    from lutbake.io.strictjson import dumps
    from lutbake.tables.lutfile import write_text_atomic

    summary = report_atlas(atlas, path, n_points, seed, search_budget)
    if out_dir:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        write_text_atomic(Path(out_dir) / REPORT_FILES[0], dumps(summary) + "\n")
    return gate(summary, max_de)
