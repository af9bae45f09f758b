"""What a glTF bake's folder holds and what to ship (docs/gltf.md, "What to ship"): the web set, what a page
drawing the asset with three.js and engine/lutbake-gltf.js fetches, and the build artefacts, each named with
what it is for. `bake --gltf --for web` writes the web set alone.

The web set, read from the manifest as the plugin reads it (loadLutbakeBake): the manifest, the atlas and
its GLSL include where a material entry is a slice, each 4D LUT a material entry names and its GLSL
include; beside them the page's modules (engine/lutbake-gltf.js and the modules it imports) and,
where a part is routed to the runtime table, that table's files (`lutbake runtime-table`).
"""

from __future__ import annotations

from pathlib import PurePath
from typing import Any

__all__ = ["PAGE_MODULES", "CACHE_FOLDER", "shipping", "is_web_member"]

PAGE_MODULES = (
    "engine/lutbake-gltf.js",
    "engine/lutbake-iridescence.js",
    "engine/lutbake-routes.js",
    "engine/lutbake-exr.js",
)
CACHE_FOLDER = ".lutbake-cache"
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
