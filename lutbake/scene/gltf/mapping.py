"""A metal-mapping file (`bake --gltf A --metal-mapping FILE.json`): which lutbake material a glTF
material's metal is, by name or index, and the mapping for the rest (docs/gltf.md). One typed, bounded
reader (lutbake/io/documents.py: a regular file of at most ``MAX_MAPPING_BYTES``); which glTF material a
key names is the asset's business (lutbake/scene/gltf/materials.py).

``{"default": "fitted" | "threejs", "materials": {"NAME or INDEX": "lutbake material"}}``: nothing else;
ValueError in one line naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass
from os import PathLike
from pathlib import Path

from lutbake.io.documents import load_json, read_text
from lutbake.physics.metals import MAPPINGS

__all__ = ["MAX_MAPPING_BYTES", "MAX_MAPPED", "MetalMapping", "read_metal_mapping"]

MAX_MAPPING_BYTES = 1 << 20
MAX_MAPPED = 100_000  # glTF materials an asset may hold (lutbake/scene/gltf/asset.py, MAX_ITEMS)


@dataclass(frozen=True)
class MetalMapping:
    """``default``: the mapping of unnamed metals; ``materials``: key (a glTF material's name or index, as
    written) → a lutbake material's name, in the file's order; ``path``: the file."""

    default: str
    materials: dict[str, str]
    path: Path


def read_metal_mapping(path: str | PathLike[str]) -> MetalMapping:
    """The checked mapping file at ``path`` (ValueError naming the file and the field)."""
    path = Path(path)
    doc = load_json(read_text(path, "metal mapping", MAX_MAPPING_BYTES), str(path))
    if not isinstance(doc, dict) or not set(doc) <= {"default", "materials"}:
        raise ValueError(f"{path}: must be an object with 'materials': {{NAME or INDEX: lutbake material}}")
    default, materials = doc.get("default", "fitted"), doc.get("materials", {})
    if not isinstance(default, str) or default not in MAPPINGS:
        raise ValueError(f"{path}: default = {default!r} is not one of {', '.join(MAPPINGS)}")
    if not isinstance(materials, dict) or len(materials) > MAX_MAPPED:
        raise ValueError(f"{path}: materials must be an object of at most {MAX_MAPPED:,} entries")
    for key, name in materials.items():
        if not isinstance(name, str):
            raise ValueError(f"{path}: materials.{key} = {name!r} is not a lutbake material name")
    return MetalMapping(default, materials, path)
