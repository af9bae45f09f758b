"""Packing a scene's slices: the atlas layout, its header, its manifest entries and its EXR.

Slices are stacked vertically, left-aligned, each in a rect [x0, y0, width, height] of texels that
sampling stays inside (docs/scene.md, Outputs). The header (format lutbake-atlas, docs/lut-format.md)
names each slice's materials, axes, film and base, so `inspect`, `sample --material` and `report`
read an atlas without its manifest; its includes (one LutbakeSlice constant per material) are rendered
by tables/includes.py.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from lutbake.tables.exr import write_image
from lutbake.tables.headers import ATLAS_FORMAT

__all__ = ["pack_atlas", "atlas_header", "slice_header", "slice_entry", "write_atlas", "ERROR_KEYS"]

# What a job's record says about its error, copied into each of its materials' manifest entries.
ERROR_KEYS = ("de00_p99", "de00_p99_bound", "target_met", "de00_max", "worst_case")

Rect = Sequence[int]  # [x0, y0, width, height] in texels


class SliceJob(Protocol):
    """What the atlas reads of a scene's slice job (lutbake/scene/plan.py's SceneJob, a layer above)."""

    @property
    def id(self) -> str: ...
    @property
    def key(self) -> dict: ...
    @property
    def materials(self) -> list: ...


class AtlasSettings(Protocol):
    """What the atlas header reads of a scene (lutbake/scene/model.py's Scene, a layer above)."""

    @property
    def space(self) -> str: ...
    @property
    def observer(self) -> str: ...
    @property
    def precision(self) -> str: ...
    @property
    def eta1(self) -> float: ...


def pack_atlas(slices: Sequence[np.ndarray]) -> dict:
    """A scene atlas's layout: slices (each (rows, columns, 3)) stacked vertically, left-aligned, each a
    rect [x0, y0, width, height] of texels that sampling stays inside; the image zero elsewhere."""
    if not slices:
        return {"width": 0, "height": 0, "rects": [], "image": None}
    width, height = max(v.shape[1] for v in slices), sum(v.shape[0] for v in slices)
    image = np.zeros((height, width, 3))
    rects, y = [], 0
    for v in slices:
        image[y : y + v.shape[0], : v.shape[1]] = v
        rects.append([0, y, v.shape[1], v.shape[0]])
        y += v.shape[0]
    return {"width": width, "height": height, "rects": rects, "image": image}


def slice_header(job: SliceJob, rect: Rect) -> dict:
    """What the atlas header says about a slice (a scene_plan.SceneJob in ``rect``): enough to sample
    it by material name."""
    x0, y0, w, h = rect
    lo, hi = job.key["thickness_nm"]
    return {
        "id": job.id,
        "rect": list(rect),
        "materials": job.materials,
        "axes": {
            "cos_theta": {"min": 0.0, "max": 1.0, "count": w, "spacing": "sqrt"},
            "thickness_nm": {"min": lo, "max": hi, "count": h, "spacing": "uniform"},
        },
        "film": job.key["film"],
        "base": job.key["base"],
    }


def atlas_header(scene: AtlasSettings, scene_hash: str, jobs: Sequence[SliceJob], rects: Sequence[Rect]) -> dict:
    """The atlas EXR's metadata: the scene's settings and one ``slice_header`` per slice job."""
    return {
        "format": ATLAS_FORMAT,
        "format_version": 1,
        "scene_hash": scene_hash,
        "space": scene.space,
        "observer": scene.observer,
        "encoding": "linear",
        "precision": scene.precision,
        "eta1": scene.eta1,
        "slices": [slice_header(j, rect) for j, rect in zip(jobs, rects)],
    }


def slice_entry(job: SliceJob, record: dict, rect: Rect, atlas: dict, exr_name: str) -> dict:
    """A slice material's manifest entry: where its rect is (texels and uv), its axes, film, base and
    what its ``record`` (scene_jobs.refine_slice) reached: p99 ΔE00, the bound held to the target, the
    searched max and where."""
    x0, y0, w, h = rect
    entry = {k: v for k, v in slice_header(job, rect).items() if k not in ("id", "materials")}
    return {
        "kind": "slice",
        "job": job.id,
        "file": exr_name,
        **entry,
        "uv_rect": [x0 / atlas["width"], y0 / atlas["height"], (x0 + w) / atlas["width"], (y0 + h) / atlas["height"]],
        **{k: record[k] for k in ERROR_KEYS},
        "constant_index_de00_p99": record["constant_index_de00_p99"],
        "sample": "lutbake_atlas_sample(atlas, LUTBAKE_<SCENE>_<MATERIAL>, cos_theta, thickness_nm)",
    }


def write_atlas(path: Path, atlas: dict, meta: dict, precision: str) -> None:
    """Write a packed atlas (``pack_atlas``) with its header (``atlas_header``), read back by ``read_lut``."""
    write_image(path, atlas["image"], meta, precision)
