"""The scene manifest (SCENE.json, which `bake --scene` and `bake --gltf` write beside their atlas): one
bounded, typed reader for everything that reads one (`bake`'s up-to-date check, `report` on a glTF
bake, `blender`), and the hash that seals it.

Read as every document is (lutbake/io/documents.py: a regular file, at most ``MAX_MANIFEST_BYTES``,
nesting and integers bounded), then checked, before any field is used: its format, the types and
ranges of every field a reader takes (docs/scene.md, "The manifest"), files named as plain names beside
it, and its seal (``manifest_hash``, the SHA-256 of the rest), so a manifest edited since lutbake wrote
it is refused in one line instead of being half-trusted. ValueError names the file and the field.

A texture-driven metal's F0 → (η3, κ3) table is written once per distinct table at the top level
(``metal_tables``, named by its metal mapping: 'fitted', 'threejs', then 'fitted-2' ...) and its part names
it (``table``: the name); ``shared_metal_tables`` makes that form from a glTF source, and the reader gives
back the source with each part's table in place, as the bake's records hold it (a manifest written before
``metal_tables``, its tables inline, reads the same).
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
from os import PathLike
from pathlib import Path
from typing import Any

from lutbake.io.documents import load_json, read_text
from lutbake.io.names import SPACES

__all__ = [
    "MANIFEST_FORMAT",
    "MAX_MANIFEST_BYTES",
    "MEMBER_SUFFIXES",
    "manifest_hash",
    "read_scene_manifest",
    "sealed",
    "shared_metal_tables",
]

MANIFEST_FORMAT = ("lutbake-scene-manifest", 1)
MAX_MANIFEST_BYTES = 256 << 20  # ~10^5 materials with their glTF records
MAX_MATERIALS = 100_000
MEMBER_SUFFIXES = (".exr", ".glsl", ".hlsl", ".json")  # a scene set's members: tables, includes, LUT headers
MAX_CURVE_NODES = 4096  # a texture-driven metal's F0 → (η3, κ3) table (65 nodes written)


def manifest_hash(manifest: dict[str, Any]) -> str:
    """SHA-256 of the manifest's content without this hash (sorted keys, compact JSON)."""
    body = {k: v for k, v in manifest.items() if k != "manifest_hash"}
    return hashlib.sha256(json.dumps(body, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def sealed(manifest: dict[str, Any]) -> dict[str, Any]:
    """``manifest`` with its ``manifest_hash``."""
    return {**manifest, "manifest_hash": manifest_hash(manifest)}


def read_scene_manifest(path: str | PathLike[str]) -> dict[str, Any]:
    """The checked manifest at ``path``; ValueError (one line naming the file and the field) when it is not
    a scene manifest lutbake wrote, or was edited since."""
    where = f"manifest {str(Path(path))!r}"
    doc = load_json(read_text(path, "manifest", MAX_MANIFEST_BYTES), where)
    if not isinstance(doc, dict) or (doc.get("format"), doc.get("format_version")) != MANIFEST_FORMAT:
        raise ValueError(
            f"{where}: format is not {MANIFEST_FORMAT[0]!r} version {MANIFEST_FORMAT[1]} "
            "(the SCENE.json that `lutbake bake --scene` or `--gltf` writes)"
        )
    try:
        named = _check(doc)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    for info in named:  # doc is this reader's own: the checked parts take their table in place
        info["table"] = doc["metal_tables"][info["table"]]
    return doc


def shared_metal_tables(source: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(a copy of a glTF ``source`` whose texture-driven metals name their table, {name: table}): one table
    per distinct table, named by its mapping ('fitted', then 'fitted-2' for a second distinct one)."""
    source, tables = copy.deepcopy(source), dict[str, Any]()
    for info in _texture_parts(source):
        table = info["table"]
        name = next((n for n, t in tables.items() if t == table), None)
        if name is None:
            taken = sum(n.split("-")[0] == info["mapping"] for n in tables)
            name = info["mapping"] + (f"-{taken + 1}" if taken else "")
            tables[name] = table
        info["table"] = name
    return source, tables


def _texture_parts(source: dict[str, Any]) -> list[dict[str, Any]]:
    """The parts of a glTF source's materials that carry a table (texture-driven metals)."""
    return [info for r in source.get("materials", []) for info in r.get("parts", {}).values() if "table" in info]


def _check(doc: dict[str, Any]) -> list[dict[str, Any]]:
    """Every field a reader takes, typed and ranged; then the seal. Returns the checked texture-driven metal
    parts that name a ``metal_tables`` entry."""
    settings = _object(doc, "settings")
    if settings.get("space") not in SPACES:
        raise ValueError(f"settings.space {_shown(settings.get('space'))} is not one of {', '.join(SPACES)}")
    _text(doc, "scene")
    _hex(_at(doc, "scene_hash"), "scene_hash", 64)
    materials = _object(doc, "materials")
    if len(materials) > MAX_MATERIALS:
        raise ValueError(f"materials: {len(materials):,} of them, at most {MAX_MATERIALS:,} are allowed")
    for name, entry in materials.items():
        _material(name, entry)
    for name, digest in _object(doc, "files").items():
        if not _plain(name, f"files.{name}").endswith(MEMBER_SUFFIXES):
            raise ValueError(f"files.{name}: not a member a scene set has (names end {', '.join(MEMBER_SUFFIXES)})")
        _hex(digest, f"files.{name}", 64)
    tables, named = _metal_tables(doc), list[dict[str, Any]]()
    if "source" in doc:
        _source(_object(doc, "source"), materials, tables, named)
    if doc.get("manifest_hash") != manifest_hash(doc):
        raise ValueError("manifest_hash does not hold: edited since lutbake wrote it (bake the scene again)")
    return named


def _material(name: str, entry: object) -> None:
    """A slice of the atlas (its rect and thickness axis) or a 4D LUT, each a file beside the manifest."""
    where = f"materials.{name}"
    if not isinstance(entry, dict):
        raise ValueError(f"{where} is not an object")
    kind = _at(entry, "kind", where)
    _plain(_at(entry, "file", where), f"{where}.file")
    if kind == "lut":
        return
    if kind != "slice":
        raise ValueError(f"{where}.kind {_shown(kind)} is not 'slice' or 'lut'")
    rect = _at(entry, "rect", where)
    if not (isinstance(rect, list) and len(rect) == 4 and all(_integer(v) and v >= 0 for v in rect)):
        raise ValueError(f"{where}.rect {_shown(rect)} is not 4 integers >= 0")
    thickness = _object(_object(entry, "axes", where), "thickness_nm", f"{where}.axes")
    low, high = (_number(thickness, k, f"{where}.axes.thickness_nm") for k in ("min", "max"))
    if not 0 <= low <= high:
        raise ValueError(f"{where}.axes.thickness_nm: min {low} and max {high} are not 0 <= min <= max")


def _metal_tables(doc: dict[str, Any]) -> dict[str, Any]:
    """``metal_tables``: at most one per material, each an F0 → (η3, κ3) table of 2 to MAX_CURVE_NODES nodes."""
    tables = _object(doc, "metal_tables") if "metal_tables" in doc else {}
    if len(tables) > MAX_MATERIALS:
        raise ValueError(f"metal_tables: {len(tables):,} of them, at most {MAX_MATERIALS:,} are allowed")
    for name in tables:
        _metal_table(_object(tables, name, "metal_tables"), f"metal_tables.{name}")
    return tables


def _metal_table(table: dict[str, Any], where: str) -> None:
    """An F0 → (η3, κ3) table: f0, eta3 and kappa3, each 2 to MAX_CURVE_NODES numbers, all of one length."""
    nodes = table.get("f0")
    count = len(nodes) if isinstance(nodes, list) and 2 <= len(nodes) <= MAX_CURVE_NODES else 0
    for key in ("f0", "eta3", "kappa3"):
        _numbers(_at(table, key, where), count, f"{where}.{key}")


def _source(
    source: dict[str, Any], materials: dict[str, Any], tables: dict[str, Any], named: list[dict[str, Any]]
) -> None:
    """A glTF bake's record of the asset (lutbake/scene/gltf/receipt.py reads it back)."""
    if _at(source, "kind", "source") != "gltf":
        return
    for key in ("asset", "metal_mapping"):
        _text(source, key, "source")
    records = _at(source, "materials", "source")
    if not isinstance(records, list) or len(records) > MAX_MATERIALS:
        raise ValueError(f"source.materials is not a list of at most {MAX_MATERIALS:,} records")
    for i, record in enumerate(records):
        where = f"source.materials[{i}]"
        if not isinstance(record, dict):
            raise ValueError(f"{where} is not an object")
        _object(record, "read", where)
        _object(record, "parts", where)
        if not isinstance(record.get("warnings", []), list):
            raise ValueError(f"{where}.warnings is not a list")
        if record.get("film") is None:
            continue
        _number(record, "film", where)
        _numbers(_at(record, "thickness_nm", where), 2, f"{where}.thickness_nm")
        for part, info in record["parts"].items():
            _part(info, materials, tables, named, f"{where}.parts.{part}")


def _part(
    info: object, materials: dict[str, Any], tables: dict[str, Any], named: list[dict[str, Any]], where: str
) -> None:
    """A part's base is numbers; a baked part names materials of this manifest, one served unbaked (``route``
    runtime: the runtime table; ``constant``: a film term that is 0) names what it would have been baked as."""
    if not isinstance(info, dict):
        raise ValueError(f"{where} is not an object")
    if "constant" in info:
        _numbers(info["constant"], 3, f"{where}.constant")
        return
    route = _at(info, "route", where) if "route" in info else "bake"
    if route not in ("bake", "runtime"):
        raise ValueError(f"{where}.route {_shown(route)} is not 'bake' or 'runtime'")
    known = materials if route == "bake" else None
    names = [info["material"]] if "material" in info else info.get("channels")
    if not isinstance(names, list) or not names or any(not _known(n, known) for n in names):
        raise ValueError(f"{where}: material or channels {_shown(names)} are not materials of this manifest")
    if "material" in info:  # a dielectric part: its base index
        _numbers(_at(info, "base", where), 2, f"{where}.base")
    else:
        _metal_part(info, tables, named, where)


def _known(name: object, materials: dict[str, Any] | None) -> bool:
    """A material name, and one of ``materials`` unless that is None (a part that was not baked)."""
    return isinstance(name, str) and (materials is None or name in materials)


def _metal_part(info: dict[str, Any], tables: dict[str, Any], named: list[dict[str, Any]], where: str) -> None:
    """A metal part, per channel: a named material, a texture's F0 → (η3, κ3) curve (a ``metal_tables``
    name, noted in ``named``; or the table itself, as a manifest written before metal_tables holds it), or
    three bases."""
    if len(info["channels"]) != 3:
        raise ValueError(f"{where}.channels: not one material per channel (3)")
    if info.get("mapping") == "named":
        _text(info, "named", where)
    elif info.get("texture"):
        _numbers(_at(info, "f0_max", where), 3, f"{where}.f0_max")
        table = _at(info, "table", where)
        if isinstance(table, dict):
            _metal_table(table, f"{where}.table")
        elif isinstance(table, str) and table in tables:
            named.append(info)
        else:
            raise ValueError(f"{where}.table {_shown(table)} is neither a metal_tables entry's name nor a table")
    else:
        for key in ("eta3", "kappa3"):
            _numbers(_at(info, key, where), 3, f"{where}.{key}")


# --- typed fields: ValueError naming the field -------------------------------------------------------------


def _at(container: dict[str, Any], key: str, where: str = "") -> Any:  # a JSON value of whatever type
    if key not in container:
        raise ValueError(f"{where}.{key} is missing" if where else f"{key} is missing")
    return container[key]


def _object(container: dict[str, Any], key: str, where: str = "") -> dict[str, Any]:
    value = _at(container, key, where)
    if not isinstance(value, dict):
        raise ValueError(f"{f'{where}.' if where else ''}{key} is not an object")
    return value


def _text(container: dict[str, Any], key: str, where: str = "") -> str:
    value = _at(container, key, where)
    if not isinstance(value, str) or not value.isprintable():
        raise ValueError(f"{f'{where}.' if where else ''}{key} {_shown(value)} is not a printable string")
    return value


def _plain(value: object, field: str) -> str:
    """A file name beside the manifest: no folder part, nothing outside it."""
    if not isinstance(value, str) or value in ("", ".", "..") or "/" in value or "\\" in value or "\0" in value:
        raise ValueError(f"{field} {_shown(value)} is not a file name beside the manifest")
    return value


def _hex(value: object, field: str, digits: int) -> None:
    if not (isinstance(value, str) and len(value) == digits and all(c in "0123456789abcdef" for c in value)):
        raise ValueError(f"{field} {_shown(value)} is not {digits} hex digits")


def _integer(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(container: dict[str, Any], key: str, where: str) -> float:
    value = _at(container, key, where)
    if not _finite(value):
        raise ValueError(f"{where}.{key} {_shown(value)} is not a finite number")
    return float(value)


def _numbers(value: object, count: int, field: str) -> list[float]:
    if not (isinstance(value, list) and len(value) == count and all(_finite(v) for v in value)):
        raise ValueError(f"{field} {_shown(value)} is not {count} finite numbers")
    return [float(v) for v in value]


def _finite(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _shown(value: object, limit: int = 60) -> str:
    """``value`` as it may stand in a one-line message: repr (no newline, no escape), cut at ``limit``."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}…"
