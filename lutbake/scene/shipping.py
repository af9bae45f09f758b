"""What a glTF bake's folder holds and what to ship (docs/gltf.md, "What to ship"): the web set, what a page
drawing the asset with three.js and engine/lutbake-gltf.js fetches, and the build artefacts, each named with
what it is for. `bake --gltf --for web` writes the web set alone.

The web set, read from the manifest as the plugin reads it (loadLutbakeBake): the manifest, the atlas and
its GLSL include where a material entry is a slice, each 4D LUT a material entry names and its GLSL
include; beside them the page's modules (engine/lutbake-gltf.js and the modules it imports) and,
where a part is routed to the runtime table, that table's files (`lutbake runtime-table`). `--for web` into a
folder that holds an earlier bake removes the build artefacts that bake wrote, as its manifest names them
(``earlier_build_artefacts``), and nothing else.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Iterable
from pathlib import Path, PurePath
from typing import Any

from lutbake.io.manifest import read_scene_manifest

__all__ = [
    "PAGE_MODULES",
    "CACHE_FOLDER",
    "shipping",
    "is_web_member",
    "earlier_build_artefacts",
    "remove_build_artefacts",
]

PAGE_MODULES = (
    "engine/lutbake-gltf.js",
    "engine/lutbake-iridescence.js",
    "engine/lutbake-routes.js",
    "engine/lutbake-exr.js",
)
CACHE_FOLDER = ".lutbake-cache"
_CACHE_ENTRY = re.compile(r"(slice|lut)-[0-9a-f]{12}\.(npy|json)")  # lutbake/scene/cache.py's names: JOB.npy, JOB.json
# A member's suffix -> what it is for, where a page does not load it.
_BUILD_ROLES = {
    ".hlsl": "HLSL includes, for Unity, Unreal and Direct3D engines",
    ".json": "4D LUT headers, for `lutbake sample` and native loaders",
    ".glsl": "GLSL includes of tables no material entry names",
    ".exr": "tables no material entry names (their parts went to the runtime table)",
}


def is_web_member(name: str, stem: str) -> bool:
    """Whether a member of a scene set belongs to the web set by its role alone: the manifest, EXR tables and
    GLSL includes (never the HLSL includes or a LUT's JSON header)."""
    suffix = PurePath(name).suffix
    return name == f"{stem}.json" or suffix in (".exr", ".glsl")


def shipping(manifest: dict[str, Any], stem: str, cache: bool = True) -> dict[str, Any]:
    """{web: the files a page fetches, page_modules, runtime_table_parts: how many parts need the runtime
    table, build: {file: what it is for} of the rest (with the cache folder where ``cache``)}."""
    web = [f"{stem}.json"]
    for entry in manifest["materials"].values():
        web += [entry["file"], str(PurePath(entry["file"]).with_suffix(".glsl"))]
    web = list(dict.fromkeys(web))
    build = {name: _BUILD_ROLES[PurePath(name).suffix] for name in sorted(manifest["files"]) if name not in web}
    if cache:
        build[f"{CACHE_FOLDER}/"] = "what the next bake of this folder reuses (incremental)"
    source = manifest.get("source") or {}
    runtime = sum(
        info.get("route") == "runtime"
        for record in source.get("materials", [])
        for info in record["parts"].values()
        if record.get("film") is not None
    )
    return {"web": web, "page_modules": list(PAGE_MODULES), "runtime_table_parts": runtime, "build": build}


def earlier_build_artefacts(out: Path, stem: str) -> list[Path]:
    """The build artefacts of the bake whose manifest ``out/stem.json`` is: the members its ship list names as
    build artefacts and its cache folder's entries (named as lutbake/scene/cache.py names them); none where
    that manifest is missing or not one lutbake wrote (its seal broken), so nobody else's file is named."""
    try:
        manifest = read_scene_manifest(out / f"{stem}.json")
    except (OSError, ValueError):
        return []
    paths = [out / name for name in shipping(manifest, stem, cache=False)["build"]]
    cache = out / CACHE_FOLDER
    return paths + (sorted(p for p in cache.iterdir() if _CACHE_ENTRY.fullmatch(p.name)) if cache.is_dir() else [])


def remove_build_artefacts(paths: Iterable[Path], keep: Iterable[Path]) -> list[str]:
    """Remove each of ``paths`` that is a file and not in ``keep`` (what the new set wrote), then the cache
    folder where it is left empty; the names removed, relative to their folder (cache entries with theirs)."""
    keep, removed = set(keep), []
    for path in paths:
        if path not in keep and path.is_file():
            path.unlink()
            removed.append(f"{CACHE_FOLDER}/{path.name}" if path.parent.name == CACHE_FOLDER else path.name)
    for path in paths:
        if path.parent.name == CACHE_FOLDER:
            with contextlib.suppress(OSError):  # not empty: something lutbake did not write stays
                path.parent.rmdir()
            break
    return removed
