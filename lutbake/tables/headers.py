"""Each table kind's header, and reading a lutbake EXR's header without trusting it: its structure, then
its metadata.

Four kinds of table share one file layout (docs/lut-format.md), told apart by the metadata's ``format``:
``KINDS`` says, per format, which versions a reader knows, the image's channels, the header's schema and how
messages name such a file. The kinds: the 4D LUT (``lutbake-lut``, lutbake/lut/bake.py), a scene's atlas of
2D slices (``lutbake-atlas``, lutbake/tables/atlas.py), the exact mode's colour-weight transform table
(``lutbake-exact``, lutbake/modes/exact.py) and the runtime table (``lutbake-runtime``,
lutbake/modes/runtime/).

``exr_header`` parses the header itself, in bounded reads (the OpenEXR file layout: magic number,
version flags, then attributes ``name\\0 type\\0 size value`` up to an empty name), so nothing is
allocated for pixels before the header has been checked. ``check_structure`` then requires what
docs/lut-format.md promises: one scanline part, exactly the channels R, G, B (R, G, B, A for the runtime
table), all HALF or all FLOAT (a UINT channel is not a colour), a data window at the origin, a lossless
compression whose worst-case ratio bounds what a file of this size can hold (a 0.9 MB file declaring
12000² float texels is refused before 1.7 GB is allocated), and the ``lutbake.metadata`` string.

``check_metadata`` validates the metadata document of each format against its schema: every key a
reader uses, its type and range, axis ranges inside the input domain (lutbake/physics/points.py), strings
printable (no terminal control sequences reach ``lutbake inspect``), the image's size and channels as the
header describes them. Failures raise ValueError whose message is the field's name;
lutfile.read_lut turns it into one line naming the file.

References: OpenEXR, "OpenEXR File Layout" (openexr.com/en/latest/OpenEXRFileLayout.html).
"""

from __future__ import annotations

import re
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from os import PathLike
from typing import IO, Any

import numpy as np

from lutbake.grid.axis import AXIS_UNITS, CORNER_AXES
from lutbake.grid.layout import TILE_ORDERS, TileLayout
from lutbake.io.documents import open_regular
from lutbake.io.names import ADMITTANCE_SPACINGS, INTERPOLATIONS, OBSERVERS, SPACES
from lutbake.physics.points import inside_domain

__all__ = [
    "FORMAT",
    "ATLAS_FORMAT",
    "EXACT_FORMAT",
    "RUNTIME_FORMAT",
    "FORMAT_VERSION",
    "EXACT_FORMAT_VERSION",
    "RUNTIME_FORMAT_VERSION",
    "TableKind",
    "KINDS",
    "exr_header",
    "check_structure",
    "check_metadata",
    "MAX_ATTRIBUTE_BYTES",
]

FORMAT = "lutbake-lut"
ATLAS_FORMAT = "lutbake-atlas"
EXACT_FORMAT = "lutbake-exact"
RUNTIME_FORMAT = "lutbake-runtime"
# LUT v2 adds the η3 axis's "admittance" spacing, v3 "root4" and the "interpolation" key, v4 the η3 axis's
# "sqrt-admittance" spacing, v5 the grazing corner's zoom on D, η3 and κ3 (docs/lut-format.md; a LUT
# without one is written as v4), v6 tiles laid along x by κ3; older LUTs (no such axis) still read.
FORMAT_VERSION = 6
EXACT_FORMAT_VERSION = 1
RUNTIME_FORMAT_VERSION = 1

_MAGIC = 20000630
_TILED, _LONG_NAMES, _DEEP, _MULTIPART = 0x200, 0x400, 0x800, 0x1000
_PIXEL_TYPES = {0: "UINT", 1: "HALF", 2: "FLOAT"}
_PIXEL_BYTES = {"HALF": 2, "FLOAT": 4}
# Lossless compressions with a known worst-case ratio (uncompressed/compressed bytes): none; RLE (127
# equal bytes in 2); deflate (258 bytes per ≥ 2 bits of a match: 1032:1), which ZIPS and ZIP use.
_COMPRESSIONS = {0: ("NO", 1), 1: ("RLE", 64), 2: ("ZIPS", 1032), 3: ("ZIP", 1032)}
# The largest attribute read: a metadata document of ~10^5 atlas slices fits.
MAX_ATTRIBUTE_BYTES = 64 << 20
_HEX = re.compile(r"^[0-9a-f]+$")


def exr_header(path: str | PathLike[str]) -> dict:
    """The header of the EXR at ``path``: {"flags", "attributes": {name: (type, bytes)}, "size"}.
    ValueError (the reason) when the file is not an EXR or its header is cut short."""
    with open_regular(path, "EXR") as fh:
        size = fh.seek(0, 2)
        fh.seek(0)
        magic, flags = struct.unpack("<iI", _read(fh, 8))
        _need(magic == _MAGIC, "not an EXR file (magic number)")
        name_limit = 255 if flags & _LONG_NAMES else 31
        attributes: dict[str, tuple[str, bytes]] = {}
        while True:
            name = _read_name(fh, name_limit)
            if not name:
                break
            kind = _read_name(fh, name_limit)
            (length,) = struct.unpack("<i", _read(fh, 4))
            _need(0 <= length <= min(MAX_ATTRIBUTE_BYTES, size - fh.tell()), f"attribute {name!r} size {length}")
            attributes[name] = (kind, _read(fh, length))
    return {"flags": flags, "attributes": attributes, "size": size}


def _read(fh: IO[bytes], n: int) -> bytes:
    data = fh.read(n)
    _need(len(data) == n, "header cut short")
    return data


def _read_name(fh: IO[bytes], limit: int) -> str:
    name = bytearray()
    while (byte := _read(fh, 1)) != b"\0":
        name += byte
        _need(len(name) <= limit, "attribute name too long")
    return name.decode("latin-1")


def _channels(data: bytes) -> dict:
    """chlist: (name\\0, int32 pixel type, uint8 pLinear, 3 reserved, int32 xSampling, int32 ySampling)*, \\0."""
    out, at = {}, 0
    while at < len(data) and data[at] != 0:
        end = data.index(b"\0", at)
        name = data[at:end].decode("latin-1")
        _need(end + 17 <= len(data), "channel list cut short")
        kind, _, xs, ys = struct.unpack("<iB3xii", data[end + 1 : end + 17])
        out[name] = (_PIXEL_TYPES.get(kind, str(kind)), xs, ys)
        at = end + 17
    return out


def check_structure(header: dict, channel_sets: Iterable[str] = ("RGB",)) -> dict:
    """(width, height, channels, pixel type, metadata text) of a header that holds one lutbake image whose
    channels are one of ``channel_sets`` ("RGB", "RGBA"); ValueError naming what is not (see the module
    docstring)."""
    attributes, flags = header["attributes"], header["flags"]
    _need(not flags & (_TILED | _DEEP | _MULTIPART), "not a single-part scanline image")
    for name, kind, size in (
        ("channels", "chlist", None),
        ("compression", "compression", 1),
        ("dataWindow", "box2i", 16),
    ):
        found, value = attributes.get(name, ("", b""))
        _need(found == kind and (size is None or len(value) == size), f"no {name} attribute of type {kind}")
    channels = _channels(attributes["channels"][1])
    names = next((c for c in channel_sets if sorted(c) == sorted(channels)), None)
    expected = " or ".join(", ".join(c) for c in channel_sets)
    if names is None:
        raise ValueError(f"channels {', '.join(sorted(channels)) or 'none'}, expected {expected}")
    kinds = {kind for kind, _, _ in channels.values()}
    _need(
        len(kinds) == 1 and kinds <= set(_PIXEL_BYTES),
        f"channel types {', '.join(sorted(kinds))}: {', '.join(names)} must all be HALF or all FLOAT",
    )
    _need(all(xs == ys == 1 for _, xs, ys in channels.values()), "subsampled channels")
    x0, y0, x1, y1 = struct.unpack("<4i", attributes["dataWindow"][1])
    _need(x0 == y0 == 0 and x1 >= 0 and y1 >= 0, f"data window ({x0}, {y0})–({x1}, {y1}) is not at the origin")
    width, height, pixel = x1 + 1, y1 + 1, kinds.pop()
    compression = attributes["compression"][1][0]
    _need(compression in _COMPRESSIONS, f"compression {compression} (readers take NO, RLE, ZIPS or ZIP)")
    name, ratio = _COMPRESSIONS[compression]
    declared = width * height * len(names) * _PIXEL_BYTES[pixel]
    _need(
        declared <= header["size"] * ratio,
        f"its data window of {width} x {height} texels cannot fit in {header['size']:,} bytes of {name} data",
    )
    kind, text = attributes.get("lutbake.metadata", ("", b""))
    _need(kind == "string", "no lutbake.metadata")
    try:
        return {"width": width, "height": height, "channels": names, "pixel": pixel, "metadata": text.decode("utf-8")}
    except UnicodeDecodeError:
        raise ValueError("lutbake.metadata is not UTF-8") from None


def _need(ok: object, why: str) -> None:
    """ValueError(why) unless ``ok`` is true (a value's truth, as ``if`` reads it)."""
    if not ok:
        raise ValueError(why)


# --- metadata: one schema per format (docs/lut-format.md); the ValueError's message is the field ---------


@dataclass(frozen=True)
class TableKind:
    """What readers know of one format: the versions they read, the image's channels, the header's schema
    (``schema(meta, structure)`` raises ValueError naming the field), and how a message names a file of it
    (``noun`` before a missing file's name, ``title`` after "is not a" for a file that is not one)."""

    versions: tuple[int, ...]
    channels: str
    schema: Callable[[dict, dict], None]
    noun: str = "LUT"
    title: str = "lutbake EXR"


def check_metadata(meta: dict, structure: dict) -> None:
    """Raise ValueError(field) when ``meta`` (its format already known) breaks its schema or does not
    describe the image ``structure`` declares."""
    kind = KINDS[meta["format"]]
    kind.schema(meta, structure)
    _need(structure["channels"] == kind.channels, "channels (image)")
    _need(meta["precision"] == {"HALF": "half", "FLOAT": "float"}[structure["pixel"]], "precision (channel type)")


def _check_lut(meta: dict, shape: dict) -> None:
    _identity(meta, hash_digits=64)
    _storage(meta)
    _choice(meta, "method", ("spectral",))
    _choice(meta, "compute", ("float64", "float32"))
    constants = _dict(meta, "constants")
    eta1 = _domain(_at(constants, "eta1", "constants"), "eta1", "constants.eta1")
    _domain(_at(constants, "eta2", "constants"), "eta2", "constants.eta2")
    axes = _at(meta, "axes")
    _need(
        isinstance(axes, list)
        and len(axes) == 4
        and all(isinstance(a, dict) for a in axes)
        and [a.get("name") for a in axes] == list(AXIS_UNITS),
        "axes",
    )
    for i, axis in enumerate(axes):
        _axis(axis, f"axes[{i}]", meta["format_version"], eta1)
    if meta["format_version"] >= 3:
        _choice(meta, "interpolation", INTERPOLATIONS)
    packing = _dict(meta, "packing")
    orders = TILE_ORDERS if meta["format_version"] >= 6 else TILE_ORDERS[:1]  # κ3 along x since v6
    _need(packing.get("tiles_x") in orders, "packing.tiles_x")
    n_cos, n_opd, n_eta3, n_kappa3 = (a["count"] for a in axes)
    expected = TileLayout(n_cos, n_opd, n_eta3, n_kappa3, tiles_x=packing["tiles_x"]).packing()
    for key, value in expected.items():
        _need(packing.get(key) == value, f"packing.{key}")
    _need((shape["width"], shape["height"]) == (expected["width"], expected["height"]), "packing (image size)")
    _spectral(_dict(meta, "spectral"))
    if "integrator" in meta:  # since the Fourier-series integrator
        _integrator(_dict(meta, "integrator"))


_ADMITTANCE_SINCE = dict(zip(ADMITTANCE_SPACINGS, (2, 4)))  # η3 spacing → first format version with it


def _axis(axis: dict, field: str, version: int, eta1: float) -> None:
    name = axis["name"]
    _need(_at(axis, "unit", field) == AXIS_UNITS[name], f"{field}.unit")
    lo, hi = (_domain(_at(axis, k, field), name, f"{field}.{k}") for k in ("min", "max"))
    _need(hi > lo, f"{field}.max")
    _integer(_at(axis, "count", field), f"{field}.count", 2, 1 << 24)
    spacing = _at(axis, "spacing", field)
    _need(
        spacing in ("uniform", "sqrt")
        or spacing == "root4"
        and version >= 3
        or spacing == "uniform-root4"
        and version >= 5
        or spacing in _ADMITTANCE_SINCE
        and name == "eta3"
        and version >= _ADMITTANCE_SINCE[spacing]
        and lo >= eta1,
        f"{field}.spacing",
    )
    if "corner" in axis:  # format v5: the grazing corner's zoom (plan.Axis)
        corner = _dict(axis, "corner", field)
        _need(version >= 5 and name in CORNER_AXES and lo == (eta1 if name == "eta3" else 0.0), f"{field}.corner")
        _integer(_at(corner, "nodes", f"{field}.corner"), f"{field}.corner.nodes", 1, axis["count"] - 2)
        _number(_at(corner, "scale", f"{field}.corner"), f"{field}.corner.scale", positive=True)


def _spectral(spectral: dict) -> None:
    _text(_at(spectral, "rule", "spectral"), "spectral.rule")
    counts = _at(spectral, "counts", "spectral")
    _need(isinstance(counts, list) and counts, "spectral.counts")
    for count in counts:
        _integer(count, "spectral.counts", 1, 1 << 24)
    span = _at(spectral, "range_nm", "spectral")
    _need(
        isinstance(span, list)
        and len(span) == 2
        and _number(span[0], "spectral.range_nm") < _number(span[1], "spectral.range_nm"),
        "spectral.range_nm",
    )
    _number(_at(spectral, "samples_per_cycle", "spectral"), "spectral.samples_per_cycle", positive=True)
    _number(_at(spectral, "error_rgb_max", "spectral"), "spectral.error_rgb_max", low=0.0)
    _integer(_at(spectral, "error_probes", "spectral"), "spectral.error_probes", 0)
    if "capped_texels" in spectral:  # since the truncation measurement (docs/stability.md)
        _integer(spectral["capped_texels"], "spectral.capped_texels", 0)
        for key in ("truncation_bound_rgb", "capped_error_rgb_max"):
            _number(_at(spectral, key, "spectral"), f"spectral.{key}", low=0.0)


_INTEGRATOR_NUMBERS = (
    "series_bound_rgb_max",
    "series_tolerance_per_polarization",
    "table_step_nm",
    "table_max_nm",
    "table_interpolation_bound",
)


def _integrator(integrator: dict) -> None:
    _text(_at(integrator, "rule", "integrator"), "integrator.rule")
    for key in ("series_texels", "direct_texels", "series_budget_terms"):
        _integer(_at(integrator, key, "integrator"), f"integrator.{key}", 0)
    for key in _INTEGRATOR_NUMBERS:
        _number(_at(integrator, key, "integrator"), f"integrator.{key}", low=0.0)
    if "closed_form_texels" in integrator:  # since the poles' closed form (docs/spectral.md)
        _integer(integrator["closed_form_texels"], "integrator.closed_form_texels", 0)
        _number(
            _at(integrator, "closed_form_bound_rgb_max", "integrator"), "integrator.closed_form_bound_rgb_max", low=0.0
        )
        closed = _dict(integrator, "closed_form", "integrator")
        for key in (
            "near_ellipse_rho",
            "bound_ellipse_rho",
            "cauchy_table_bound",
            "chebyshev_degree",
            "max_near_poles",
        ):
            _number(_at(closed, key, "integrator.closed_form"), f"integrator.closed_form.{key}", low=0.0)


def _check_atlas(meta: dict, shape: dict) -> None:
    _storage(meta)
    _need(_is_hex(_at(meta, "scene_hash"), 64), "scene_hash")
    _domain(_at(meta, "eta1"), "eta1", "eta1")
    slices = _at(meta, "slices")
    _need(isinstance(slices, list) and slices and all(isinstance(s, dict) for s in slices), "slices")
    names: set[str] = set()
    for i, s in enumerate(slices):
        _slice(s, f"slices[{i}]", shape, names)


def _slice(s: dict, field: str, shape: dict, names: set[str]) -> None:
    if "id" in s:
        _text(s["id"], f"{field}.id")
    rect = _at(s, "rect", field)
    _need(isinstance(rect, list) and len(rect) == 4, f"{field}.rect")
    x0, y0, w, h = (_integer(v, f"{field}.rect", 0) for v in rect)
    _need(w >= 2 and h >= 1 and x0 + w <= shape["width"] and y0 + h <= shape["height"], f"{field}.rect")
    materials = _at(s, "materials", field)
    _need(isinstance(materials, list) and materials, f"{field}.materials")
    for m in materials:
        _need(_text(m, f"{field}.materials") and m not in names, f"{field}.materials")
        names.add(m)
    axes = _dict(s, "axes", field)
    cos, th = _dict(axes, "cos_theta", f"{field}.axes"), _dict(axes, "thickness_nm", f"{field}.axes")
    _need(
        (cos.get("min"), cos.get("max"), cos.get("count"), cos.get("spacing")) == (0.0, 1.0, w, "sqrt"),
        f"{field}.axes.cos_theta",
    )
    lo, hi = (
        _domain(_at(th, k, f"{field}.axes.thickness_nm"), "thickness_nm", f"{field}.axes.thickness_nm.{k}")
        for k in ("min", "max")
    )
    _need(hi >= lo and th.get("count") == h and th.get("spacing") == "uniform", f"{field}.axes.thickness_nm")
    film, base = _at(s, "film", field), _at(s, "base", field)
    if isinstance(film, str):
        _text(film, f"{field}.film")
    else:
        _domain(film, "eta2", f"{field}.film")
    if isinstance(base, str):
        _text(base, f"{field}.base")
    else:
        _need(isinstance(base, list) and len(base) == 2, f"{field}.base")
        _domain(base[0], "eta3", f"{field}.base")
        _domain(base[1], "kappa3", f"{field}.base")


def _check_exact(meta: dict, shape: dict) -> None:
    _identity(meta, hash_digits=16)
    _storage(meta)
    table = _dict(meta, "table")
    _number(_at(table, "step_nm", "table"), "table.step_nm", positive=True)
    width = _integer(_at(table, "width", "table"), "table.width", 1)
    rows = _integer(_at(table, "rows_per_part", "table"), "table.rows_per_part", 1)
    _need(_integer(_at(table, "texels", "table"), "table.texels", 2) == width * rows, "table.texels")
    _number(_at(table, "x_max_nm", "table"), "table.x_max_nm", positive=True)
    _number(_at(table, "nu0_per_nm", "table"), "table.nu0_per_nm")
    _choice(table, "interpolation", ("linear",), "table")
    for key in ("quantity", "layout"):
        _text(_at(table, key, "table"), f"table.{key}")
    _need((shape["width"], shape["height"]) == (width, 2 * rows), "table (image size)")
    for block, keys in (
        ("tail", ("mass", "edge", "variation")),
        ("error", ("interpolation_bound", "transform_bound", "storage_max")),
    ):
        values = _dict(meta, block)
        for key in keys:
            _number(_at(values, key, block), f"{block}.{key}", low=0.0)
    include = _dict(meta, "include")
    _need(0 < _number(_at(include, "tolerance", "include"), "include.tolerance") < 1, "include.tolerance")
    _integer(_at(include, "max_terms", "include"), "include.max_terms", 1, 4096)


def _check_runtime(meta: dict, shape: dict) -> None:
    """The runtime table (lutbake/modes/runtime/files.py): its slices' tiles, band by band, fill the image."""
    _identity(meta, hash_digits=16, channels="RGBA")
    _storage(meta)
    table = _dict(meta, "table")
    for key in ("x_max_nm", "zoom_nm", "nu0_per_nm"):
        _number(_at(table, key, "table"), f"table.{key}", positive=True)
    _choice(table, "x_spacing", ("sqrt",), "table")
    for key in ("quantity", "layout"):
        _text(_at(table, key, "table"), f"table.{key}")
    slices, nodes = (_integer(_at(table, key, "table"), f"table.{key}", 2, 1 << 16) for key in ("slices", "nodes"))
    tiles = _integer(_at(table, "tiles_per_row", "table"), "table.tiles_per_row", 1, 1 << 16)
    band_rows = _integer(_at(table, "band_rows", "table"), "table.band_rows", 1)
    _need(band_rows == -(-(slices - 1) // tiles), "table.band_rows")  # the pairs of slices, tiles_per_row a row
    white = _at(table, "white", "table")
    _need(isinstance(white, list) and len(white) == 3, "table.white")
    for value in white:
        _number(value, "table.white", positive=True)
    size = tuple(_integer(_at(table, key, "table"), f"table.{key}", 1) for key in ("width", "height"))
    _need(size == (tiles * nodes, 3 * band_rows * nodes) == (shape["width"], shape["height"]), "table (image size)")
    _number(_at(_dict(meta, "error"), "storage_max", "error"), "error.storage_max", low=0.0)


def _identity(meta: dict, hash_digits: int, channels: str = "RGB") -> None:
    """What LUTs, exact and runtime tables say about their origin: writer version, content hash, weighting."""
    _text(_at(meta, "lutbake_version"), "lutbake_version")
    _need(_is_hex(_at(meta, "content_hash"), hash_digits), "content_hash")
    _text(_at(meta, "illuminant"), "illuminant")
    _need(_at(meta, "channels") == list(channels), "channels")


def _storage(meta: dict) -> None:
    """Colour settings and storage, in every format."""
    _choice(meta, "observer", tuple(OBSERVERS))
    _choice(meta, "space", tuple(SPACES))
    _choice(meta, "encoding", ("linear",))
    _choice(meta, "precision", ("float", "half"))


def _at(container: dict, key: str, parent: str = "") -> Any:  # a JSON value, of whatever type it holds
    """``container[key]``, or ValueError naming the missing field."""
    if key not in container:
        raise ValueError(f"{parent}.{key}" if parent else key)
    return container[key]


def _dict(container: dict, key: str, parent: str = "") -> dict:
    value = _at(container, key, parent)
    _need(isinstance(value, dict), f"{parent}.{key}" if parent else key)
    return value


def _choice(container: dict, key: str, allowed: Iterable[str], parent: str = "") -> str:
    value = _at(container, key, parent)
    _need(isinstance(value, str) and value in allowed, f"{parent}.{key}" if parent else key)
    return value


def _text(value: object, field: str) -> bool:
    """A non-empty printable string (no newline or escape sequence reaches a terminal)."""
    _need(isinstance(value, str) and value != "" and value.isprintable(), field)
    return True


def _is_hex(value: object, digits: int) -> bool:
    return isinstance(value, str) and len(value) == digits and _HEX.match(value) is not None


def _number(value: Any, field: str, low: float | None = None, positive: bool = False) -> float:
    _need(
        isinstance(value, (int, float))
        and not isinstance(value, bool)
        and bool(np.isfinite(value))
        and (low is None or value >= low)
        and (not positive or value > 0),
        field,
    )
    return float(value)


def _integer(value: Any, field: str, low: int | None = None, high: int | None = None) -> int:
    _need(
        isinstance(value, int)
        and not isinstance(value, bool)
        and (low is None or value >= low)
        and (high is None or value <= high),
        field,
    )
    return value


def _domain(value: Any, name: str, field: str) -> float:
    """A number inside the input domain of ``name`` (docs/stability.md, Input domain)."""
    _need(inside_domain(name, _number(value, field)), field)
    return float(value)


KINDS = {
    FORMAT: TableKind((1, 2, 3, 4, 5, 6), "RGB", _check_lut),
    ATLAS_FORMAT: TableKind((1,), "RGB", _check_atlas),
    EXACT_FORMAT: TableKind((EXACT_FORMAT_VERSION,), "RGB", _check_exact),
    RUNTIME_FORMAT: TableKind(
        (RUNTIME_FORMAT_VERSION,), "RGBA", _check_runtime, "runtime table", "readable lutbake runtime table"
    ),
}
