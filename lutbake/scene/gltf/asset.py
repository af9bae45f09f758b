"""Reading a glTF 2.0 asset's JSON (.gltf, or the JSON chunk of a .glb) by the specification, bounded.

lutbake needs the materials, which mesh primitives use them (directly and through
KHR_materials_variants) and that the buffers the asset names exist; never the geometry or the
images. So the container is read by the spec (glTF 2.0, section 4.4 "GLB File Format
Specification") instead of through a glTF library: a .glb's 12-byte header and chunk headers are
checked against the file's size before anything else is read, its binary chunk is never loaded,
and the JSON goes through documents.load_json (bounded size and nesting). A library such as
pygltflib reads the whole file, binary chunk included, and checks no types, so every check below
would be needed on top of it anyway.

Everything malformed raises ValueError with one line naming the file and the JSON path:
``lamp.glb: meshes[0].primitives[2].material = 9 is not allowed: the asset has 3 materials``.
Buffer views must lie in their buffers and accessors in their views (a huge ``count`` is refused);
an external .bin that is absent is only a warning (lutbake reads no geometry, and pipelines often
hand it the JSON alone), one that is present but shorter than its byteLength is an error.
"""

from __future__ import annotations

import builtins
import os
import re
import struct
from os import PathLike
from pathlib import Path, PurePosixPath
from typing import IO, Any, TypeGuard
from urllib.parse import unquote

from lutbake.io.documents import load_json, read_text

__all__ = ["GltfAsset", "read_gltf", "MAX_JSON_BYTES", "MAX_ITEMS"]

MAX_JSON_BYTES = 64 << 20  # the JSON of the largest Khronos sample asset is ~1 MB
MAX_ITEMS = 100_000  # materials, meshes, primitives per mesh, buffers: far beyond real assets
_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942


class GltfAsset:
    """The JSON document of a glTF asset (``doc``), with typed, checked access to what lutbake reads."""

    def __init__(self, path: Path | str, doc: dict[str, Any], bin_bytes: int | None):
        self.path, self.doc, self.bin_bytes = Path(path), doc, bin_bytes
        self.warnings: list[str] = []  # what lutbake does not need but an engine will (missing external buffers)
        self._check_asset()
        self.materials = self.array("materials", dict)
        self.textures = self.array("textures", dict)

    def error(self, where: str, message: str) -> ValueError:
        """'FILE: WHERE = VALUE …' for a message that starts with '= ', else 'FILE: WHERE: MESSAGE'."""
        joint = "" if not where else " " if message.startswith("= ") else ": "
        return ValueError(f"{self.path}: {where}{joint}{message}")

    def array(self, key: str, item_type: type, parent: dict[str, Any] | None = None, where: str = "") -> list[Any]:
        """``parent[key]`` (the document's by default): a list of at most MAX_ITEMS ``item_type``, or []."""
        parent = self.doc if parent is None else parent
        name = f"{where}.{key}" if where else key
        value = parent.get(key, [])
        if not isinstance(value, list):
            raise self.error(name, f"must be an array, not {type(value).__name__}")
        if len(value) > MAX_ITEMS:
            raise self.error(name, f"has {len(value):,} items: at most {MAX_ITEMS:,} are allowed")
        for i, item in enumerate(value):
            if not isinstance(item, item_type) or isinstance(item, bool):
                raise self.error(f"{name}[{i}]", f"must be {_TYPE_NAMES[item_type]}, not {type(item).__name__}")
        return value

    def object(self, parent: dict[str, Any], key: str, where: str) -> dict[str, Any]:
        value = parent.get(key, {})
        if not isinstance(value, dict):
            raise self.error(f"{where}.{key}", f"must be an object, not {type(value).__name__}")
        return value

    def index(self, value: builtins.object, count: int, where: str, what: str) -> int:
        """An index into an array of ``count`` ``what``."""
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < count:
            raise self.error(where, f"= {value!r} is not allowed: the asset has {count} {what}")
        return value

    def used_materials(self) -> dict[int, list[str]]:
        """Material index → how mesh primitives use it: 'primitive' and/or the names of the
        KHR_materials_variants variants that map it."""
        root = self.object(self.object(self.doc, "extensions", ""), "KHR_materials_variants", "extensions")
        variants = self.array("variants", dict, root, "extensions.KHR_materials_variants")
        names = [str(v.get("name", f"variant {i}")) for i, v in enumerate(variants)]
        used: dict[int, list[str]] = {}
        for m, mesh in enumerate(self.array("meshes", dict)):
            for p, prim in enumerate(self.array("primitives", dict, mesh, f"meshes[{m}]")):
                where = f"meshes[{m}].primitives[{p}]"
                if "material" in prim:
                    i = self.index(prim["material"], len(self.materials), f"{where}.material", "materials")
                    used.setdefault(i, []).append("primitive")
                ext = self.object(
                    self.object(prim, "extensions", where), "KHR_materials_variants", f"{where}.extensions"
                )
                for k, mapping in enumerate(
                    self.array("mappings", dict, ext, f"{where}.extensions.KHR_materials_variants")
                ):
                    at = f"{where}.extensions.KHR_materials_variants.mappings[{k}]"
                    i = self.index(mapping.get("material"), len(self.materials), f"{at}.material", "materials")
                    for j, v in enumerate(self.array("variants", int, mapping, at)):
                        used.setdefault(i, []).append(
                            names[self.index(v, len(names), f"{at}.variants[{j}]", "variants")]
                        )
        return {i: sorted(set(u), key=u.index) for i, u in sorted(used.items())}

    def _check_asset(self) -> None:
        asset = self.doc.get("asset")
        if not isinstance(asset, dict) or not isinstance(asset.get("version"), str):
            raise self.error("asset.version", "is missing: not a glTF asset")
        if not asset["version"].startswith("2."):
            raise self.error("asset.version", f"= {asset['version']!r}: lutbake reads glTF 2.x")
        buffers = self.array("buffers", dict)
        for i, buffer in enumerate(buffers):
            self._check_buffer(i, buffer)
        self._check_views(buffers)

    def _check_buffer(self, i: int, buffer: dict[str, Any]) -> None:
        """A buffer's byteLength is a positive integer its data can hold: the .glb's binary chunk
        (no uri), a data: URI, or a file beside the asset."""
        where, length = f"buffers[{i}]", buffer.get("byteLength")
        if not isinstance(length, int) or isinstance(length, bool) or length < 1:
            raise self.error(f"{where}.byteLength", f"= {length!r} is not allowed: must be an integer >= 1")
        uri = buffer.get("uri")
        if uri is None:
            if self.bin_bytes is None or i != 0:
                raise self.error(where, "has no uri and is not the .glb's binary chunk")
            size, source = self.bin_bytes, "the binary chunk"
        elif not isinstance(uri, str):
            raise self.error(f"{where}.uri", f"must be a string, not {type(uri).__name__}")
        elif uri.startswith("data:"):
            return  # embedded: its size is the asset's, already bounded
        else:
            file = _beside(self.path.parent, uri)
            if file is None or not file.is_file():  # lutbake reads no geometry: the JSON alone can be baked
                self.warnings.append(
                    f"{where}.uri {uri!r} is not a file in the asset's folder: not read by lutbake, but "
                    "an engine loading the asset needs it"
                )
                return
            size, source = file.stat().st_size, repr(uri)
        if size < length:
            raise self.error(f"{where}.byteLength", f"= {length:,} but {source} holds {size:,} bytes (truncated)")

    def _check_views(self, buffers: list[dict[str, Any]]) -> None:
        """Buffer views inside their buffers, accessors inside their views (no count past the data)."""
        views = self.array("bufferViews", dict)
        for i, view in enumerate(views):
            where = f"bufferViews[{i}]"
            b = self.index(view.get("buffer"), len(buffers), f"{where}.buffer", "buffers")
            end = self._size(view, "byteOffset", where, 0) + self._size(view, "byteLength", where)
            if end > buffers[b]["byteLength"]:
                raise self.error(where, f"ends at byte {end:,}, past buffers[{b}]'s {buffers[b]['byteLength']:,}")
        for i, accessor in enumerate(self.array("accessors", dict)):
            where = f"accessors[{i}]"
            count = self._size(accessor, "count", where)
            if "bufferView" not in accessor:
                continue
            view = views[self.index(accessor["bufferView"], len(views), f"{where}.bufferView", "bufferViews")]
            element = self._element_bytes(accessor, where)
            stride = self._stride(view, element, f"bufferViews[{accessor['bufferView']}]")
            end = self._size(accessor, "byteOffset", where, 0) + stride * (count - 1) + element
            if count and end > view["byteLength"]:
                raise self.error(
                    f"{where}.count", f"= {count:,} needs {end:,} bytes; its buffer view has {view['byteLength']:,}"
                )

    def _element_bytes(self, accessor: dict[str, Any], where: str) -> int:
        """The bytes of one element of ``accessor``: its componentType's size times its type's components."""
        component, kind = accessor.get("componentType"), accessor.get("type")
        if not _integer(component) or component not in _COMPONENT_BYTES:
            raise self.error(f"{where}.componentType", f"= {component!r} is not one glTF 2.0 defines")
        if not isinstance(kind, str) or kind not in _TYPE_COMPONENTS:
            raise self.error(f"{where}.type", f"= {kind!r} is not one glTF 2.0 defines")
        return _COMPONENT_BYTES[component] * _TYPE_COMPONENTS[kind]

    def _stride(self, view: dict[str, Any], element: int, where: str) -> int:
        """A buffer view's byteStride (glTF 2.0: an integer in 4..252, a multiple of 4, here at least one
        element), or ``element`` when the view is tightly packed."""
        stride: int = view.get("byteStride", element)
        if "byteStride" in view and not (_integer(stride) and 4 <= stride <= 252 and stride % 4 == 0):
            raise self.error(f"{where}.byteStride", f"= {stride!r} is not allowed: must be 4..252, a multiple of 4")
        if stride < element:
            raise self.error(f"{where}.byteStride", f"= {stride} is shorter than its accessor's {element}-byte element")
        return stride

    def _size(self, parent: dict[str, Any], key: str, where: str, default: int | None = None) -> int:
        value = parent.get(key, default)
        if not _integer(value) or value < 0:
            raise self.error(f"{where}.{key}", f"= {value!r} is not allowed: must be an integer >= 0")
        return value


def _integer(value: object) -> TypeGuard[int]:
    return isinstance(value, int) and not isinstance(value, bool)


def _beside(folder: Path, uri: str) -> Path | None:
    """The file a relative buffer ``uri`` names inside ``folder`` (percent-decoded, every symbolic link on the
    way followed while it stays inside), or None where the URI has a scheme or any step leaves the folder:
    nothing outside the asset's folder is looked at, so nothing there changes what lutbake says."""
    if _SCHEME.match(uri) or uri.startswith("/"):
        return None
    root = current = folder.resolve()
    pending, links = list(PurePosixPath(unquote(uri)).parts), 0
    while pending:
        part = pending.pop(0)
        if part == "..":
            if current == root:
                return None
            current = current.parent
        elif part not in ("", ".", "/"):
            step = current / part
            if not step.is_symlink():
                current = step
                continue
            target, links = os.readlink(step), links + 1
            if os.path.isabs(target) or links > _MAX_LINKS:
                return None
            pending[:0] = PurePosixPath(target).parts
    return current


_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]*:")  # RFC 3986: http:, file:, … (data: is read before)
_MAX_LINKS = 40  # symbolic links followed for one URI, as Linux's own bound
_TYPE_NAMES = {dict: "an object", int: "an integer", list: "an array", str: "a string"}
_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}


def read_gltf(path: str | PathLike[str]) -> GltfAsset:
    """The asset at ``path`` (.gltf or .glb, told apart by the GLB magic), checked as far as lutbake
    reads it; ValueError (one line) when it is malformed."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"glTF {str(path)!r} does not exist")
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if len(magic) == 4 and struct.unpack("<I", magic)[0] == _GLB_MAGIC:
        text, bin_bytes = _glb_json(path)
    else:
        text, bin_bytes = read_text(path, "glTF", MAX_JSON_BYTES), None
    doc = load_json(text, str(path))
    if not isinstance(doc, dict):
        raise ValueError(f"{path}: the glTF JSON must be an object, not {type(doc).__name__}")
    return GltfAsset(path, doc, bin_bytes)


def _glb_json(path: Path) -> tuple[str, int | None]:
    """(JSON chunk text, binary chunk length or None) of a .glb, every length checked against the file."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        header = fh.read(12)
        if len(header) < 12:
            raise ValueError(f"{path}: truncated GLB header ({len(header)} of 12 bytes)")
        _, version, length = struct.unpack("<III", header)
        if version != 2:
            raise ValueError(f"{path}: GLB version {version}: lutbake reads version 2")
        if length != size:
            raise ValueError(f"{path}: the GLB header declares {length:,} bytes, the file has {size:,} (truncated?)")
        json_length, json_type = _chunk_header(fh, path, size)
        if json_type != _JSON_CHUNK:
            raise ValueError(f"{path}: the first GLB chunk is not JSON (type 0x{json_type:08x})")
        if json_length > MAX_JSON_BYTES:
            raise ValueError(f"{path}: GLB JSON chunk of {json_length:,} bytes: at most {MAX_JSON_BYTES:,} are allowed")
        data = fh.read(json_length)
        bin_bytes = None
        if fh.tell() < size:
            bin_length, bin_type = _chunk_header(fh, path, size)
            bin_bytes = bin_length if bin_type == _BIN_CHUNK else None
    try:
        return data.decode("utf-8"), bin_bytes
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: GLB JSON chunk is not UTF-8 (byte {exc.start})") from None


def _chunk_header(fh: IO[bytes], path: Path, size: int) -> tuple[int, int]:
    """(length, type) of the chunk at the file position, its data checked to lie inside the file."""
    head = fh.read(8)
    if len(head) < 8:
        raise ValueError(f"{path}: truncated GLB chunk header at byte {fh.tell() - len(head)}")
    length, kind = struct.unpack("<II", head)
    if length % 4 or fh.tell() + length > size:
        raise ValueError(
            f"{path}: GLB chunk at byte {fh.tell() - 8} declares {length:,} bytes: past the end "
            f"of the file ({size:,} bytes) or not a multiple of 4"
        )
    return length, kind
