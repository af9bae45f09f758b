"""Which report a file gets (`lutbake report PATH`): a glTF bake's manifest (.json) its receipts
(lutbake/scene/gltf/receipt.py), a scene atlas its per-slice errors, a LUT its full report
(lutbake/quality/summaries.py), a runtime table its error over the base boxes with its searched maxima
(lutbake/quality/runtime_accuracy.py).

Everything that can be refused is refused before any work: a gate that is not a number > 0, an output
folder whose report files would overwrite the input, a file that is none of the three.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from lutbake.errors import ParameterError
from lutbake.io.fileset import refuse_overwriting_inputs
from lutbake.io.progress import no_progress
from lutbake.lut.sample import ATLAS_FORMAT, FORMAT, Atlas, Lut
from lutbake.modes.runtime.files import RuntimeTable
from lutbake.quality.refine import check_max_de
from lutbake.quality.report import REPORT_FILES
from lutbake.scene.gltf.receipt import RECEIPT_FILES
from lutbake.tables.headers import RUNTIME_FORMAT
from lutbake.tables.lutfile import read_lut

__all__ = ["FileReport", "open_report", "GLTF_RECEIPT_POINTS"]

GLTF_RECEIPT_POINTS = 10_000  # at most this many points per part of a glTF material's receipt (more: refused)


def open_report(
    path: str | PathLike[str], out_dir: str | PathLike[str] | None = None, max_de: float | None = None
) -> FileReport:
    """The report of the file at ``path``, checked and its table loaded (``FileReport.run`` scores it).
    ``out_dir``: the folder to write it into; ``max_de``: the p99 ΔE00 gate (a LUT's or an atlas's).
    ParameterError for a ``max_de`` not > 0 or an ``out_dir`` where the report would overwrite ``path``;
    ValueError naming the file when it is not a LUT, an atlas or a glTF bake's manifest.

    >>> open_report("lut.exr", out_dir=".", max_de=0.0)
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: max_de 0.0 is not allowed: must be a number > 0
    """
    if max_de is not None:
        check_max_de(max_de)
    if out_dir:
        names = (*REPORT_FILES, *RECEIPT_FILES)  # what the input turns out to be is not known yet
        refuse_overwriting_inputs({"input": path}, [Path(out_dir) / name for name in names])
    table = None if Path(path).suffix.lower() == ".json" else _load(path)
    return FileReport(path, table, out_dir, max_de)


def _load(path: str | PathLike[str]) -> Lut | Atlas | RuntimeTable:
    """A Lut, an Atlas or a RuntimeTable, whichever the EXR holds."""
    meta, image = read_lut(path, (FORMAT, ATLAS_FORMAT, RUNTIME_FORMAT))
    if meta["format"] == RUNTIME_FORMAT:
        return RuntimeTable(meta, image.astype(np.float32))
    return (Atlas if meta["format"] == ATLAS_FORMAT else Lut)(meta, image)


@dataclass
class FileReport:
    """A file to report: ``table`` its Lut, Atlas or RuntimeTable (None for a glTF bake's manifest)."""

    path: str | PathLike[str]
    table: Lut | Atlas | RuntimeTable | None
    out_dir: str | PathLike[str] | None = None
    max_de: float | None = None

    @property
    def kind(self) -> str:
        """'gltf' (receipts), 'atlas', 'runtime' or 'lut'."""
        if self.table is None:
            return "gltf"
        return (
            "atlas" if isinstance(self.table, Atlas) else "runtime" if isinstance(self.table, RuntimeTable) else "lut"
        )

    def run(
        self,
        n_points: int = 1000,
        seed: int = 0,
        approximations: bool = True,
        search_budget: int | None = None,
        progress: Callable[[int, int | None, str], None] = no_progress,
        device: str | None = None,
    ) -> dict[str, Any]:
        """The report's document, written into ``out_dir`` when given: a glTF bake's receipts (at most
        GLTF_RECEIPT_POINTS points per part, more refused; gated by ``max_de``; receipts.json and .html),
        or the summary of an atlas (``atlas_summary``), a runtime table (``runtime_table_summary``) or a LUT
        (``lut_summary``: with ``approximations``, the stand-in truth of its searches on OpenCL ``device``),
        each row's max searched with ``search_budget`` evaluations (None: the report's default for the kind)."""
        if self.kind == "gltf":
            from lutbake.scene.gltf.receipt import gltf_receipts, write_receipts

            if n_points > GLTF_RECEIPT_POINTS:
                raise ParameterError(
                    "{n_points} {value} is not allowed for a glTF bake's receipts: at most {bound} per part",
                    value=n_points,
                    bound=GLTF_RECEIPT_POINTS,
                )
            receipts = gltf_receipts(self.path, n_points, seed, self.max_de, progress)
            if self.out_dir:
                write_receipts(receipts, self.out_dir)
            return receipts
        from lutbake.quality.summaries import atlas_summary, lut_summary

        if isinstance(self.table, RuntimeTable):  # kind 'runtime'
            from lutbake.quality.runtime_accuracy import runtime_table_summary

            budget = {"budget": search_budget} if search_budget else {}
            return runtime_table_summary(self.table, n_points, seed, out_dir=self.out_dir, max_de=self.max_de, **budget)
        budget = {"search_budget": search_budget} if search_budget else {}
        if isinstance(self.table, Atlas):  # kind 'atlas'
            return atlas_summary(self.table, self.path, n_points, seed, self.out_dir, self.max_de, **budget)
        return lut_summary(
            self.path,
            n_points,
            seed,
            self.out_dir,
            self.max_de,
            approximations,
            progress=progress,
            device=device,
            **budget,
        )
