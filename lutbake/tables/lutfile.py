"""The LUT file: a self-describing EXR, a JSON sidecar, GLSL and HLSL includes.

The EXR holds R, G, B (float32 or half, ZIP compression, which every
OpenEXR 3.x reader decodes) in the tile packing of lutbake/grid/spec.py. Metadata go in
string attributes: ``lutbake.metadata`` holds the whole description as JSON
(doubles written with Python's shortest round-trip repr, so they come back
bit-exact; a plain float attribute would be stored as 32-bit), and flat
``lutbake.*`` attributes repeat the key fields for tools such as
``oiiotool --info -v``. docs/lut-format.md specifies it for engine authors.

A LUT's four files are one set (lutbake/io/fileset.py): written as hidden temporaries,
then committed together, so an interrupted or failed bake leaves the
previous set (or none), never a partial or mixed one. Nothing time- or machine-dependent is written:
the same inputs give the same bytes.
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import json
import os
import string
import struct
import sys
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from lutbake.grid.axis import ROOT4_WEIGHT
from lutbake.grid.interpolation import mirrors_low_end
from lutbake.io import fileset
from lutbake.io.documents import load_json
from lutbake.io.fileset import temporary_for
from lutbake.io.names import ADMITTANCE_SPACINGS, shader_comment
from lutbake.io.names import shader_identifier as shader_ident
from lutbake.tables.headers import check_metadata, check_structure, exr_header

__all__ = [
    "FORMAT",
    "ATLAS_FORMAT",
    "EXACT_FORMAT",
    "FORMAT_VERSION",
    "EXACT_FORMAT_VERSION",
    "exr_rows",
    "exr_stream",
    "read_lut",
    "write_atlas",
    "write_text_atomic",
    "atomic_path",
    "shader_includes",
    "shader_ident",
    "shader_template",
    "flat_attributes",
    "MAX_TEXTURE_SIZE",
]

FORMAT = "lutbake-lut"
ATLAS_FORMAT = "lutbake-atlas"  # a scene's 2D slices (lutbake/tables/atlas.py, write_atlas)
EXACT_FORMAT = "lutbake-exact"  # the exact runtime mode's colour-weight transform table (lutbake/modes/exact.py)
# LUT v2 adds the η3 axis's "admittance" spacing, v3 "root4" and the "interpolation" key, v4 the η3 axis's
# "sqrt-admittance" spacing, v5 the grazing corner's zoom on D, η3 and κ3 (docs/lut-format.md; a LUT
# without one is written as v4); older LUTs (no such axis) still read.
FORMAT_VERSION = 6
EXACT_FORMAT_VERSION = 1
_READABLE_VERSIONS = {FORMAT: (1, 2, 3, 4, 5, 6), ATLAS_FORMAT: (1,), EXACT_FORMAT: (EXACT_FORMAT_VERSION,)}
# Larger than most desktop GPUs' guarantee; WebGL2 guarantees only 2048, many mobile GPUs 4096.
MAX_TEXTURE_SIZE = 8192


@contextlib.contextmanager
def atomic_path(final: Path):
    """Yield a temporary path beside ``final``; rename it into place on success.

    The temporary is removed when the block raises (the CLI turns SIGTERM into
    an exception; a process killed outright leaves only the hidden temporary,
    which the next bake into the folder removes). Single files only: a LUT or
    scene file set is committed as one unit by fileset.open_set.
    """
    final = Path(final)
    tmp = temporary_for(final)
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_text_atomic(path: Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def flat_attributes(meta: dict, prefix: str = "lutbake") -> dict:
    """Key metadata as flat string attributes (doubles as exact repr)."""
    out = {}
    for key, value in meta.items():
        name = f"{prefix}.{key}"
        if isinstance(value, dict):
            out.update(flat_attributes(value, name))
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            for i, item in enumerate(value):
                label = item.get("name", item.get("id", str(i)))
                out.update(
                    flat_attributes({k: v for k, v in item.items() if k not in ("name", "id")}, f"{name}.{label}")
                )
        else:
            out[name] = value if isinstance(value, str) else json.dumps(value)
    return out


class _ExrRows:
    """An open EXR receiving bands of rows in order."""

    def __init__(self, path: Path, width: int, height: int, meta: dict, precision: str):
        import Imath
        import OpenEXR

        self.height = height
        self.dtype = np.float16 if precision == "half" else np.float32
        pixel = Imath.PixelType(Imath.PixelType.HALF if precision == "half" else Imath.PixelType.FLOAT)
        header = OpenEXR.Header(width, height)
        header["channels"] = {c: Imath.Channel(pixel) for c in "RGB"}
        header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
        header["lutbake.metadata"] = json.dumps(meta, sort_keys=True).encode()
        for key, value in flat_attributes(meta).items():
            header[key] = value.encode()
        self.file = OpenEXR.OutputFile(str(path), header)
        self.rows_written = 0

    def write_rows(self, rgb: np.ndarray) -> np.ndarray:
        """Append a band (rows, width, 3); return it as stored (rounded to the file's precision)."""
        stored = np.ascontiguousarray(rgb, dtype=self.dtype)
        planes = {c: np.ascontiguousarray(stored[:, :, i]).tobytes() for i, c in enumerate("RGB")}
        self.file.writePixels(planes, stored.shape[0])
        self.rows_written += stored.shape[0]
        return stored


@contextlib.contextmanager
def exr_rows(path: Path, width: int, height: int, meta: dict, precision: str = "float"):
    """Write an RGB EXR at ``path`` band by band (bounded memory); raise if left incomplete."""
    rows = _ExrRows(path, width, height, meta, precision)
    try:
        yield rows
    finally:
        rows.file.close()
    if rows.rows_written != height:
        raise RuntimeError(f"LUT incomplete: {rows.rows_written} of {height} rows written")


@contextlib.contextmanager
def exr_stream(path: Path, width: int, height: int, meta: dict, precision: str = "float"):
    """exr_rows into a temporary: the file appears only when complete."""
    with atomic_path(path) as tmp, exr_rows(tmp, width, height, meta, precision) as rows:
        yield rows


def write_atlas(path: Path, atlas: dict, meta: dict, precision: str) -> None:
    """Write a packed atlas (atlas.pack_atlas) with its header (format ATLAS_FORMAT, read by ``read_lut``)."""
    with exr_rows(path, atlas["width"], atlas["height"], meta, precision) as exr:
        exr.write_rows(atlas["image"])


def read_lut(path, formats=(FORMAT,)):
    """(metadata dict, image array (height, width, 3) as stored) of a lutbake EXR whose format is
    one of ``formats`` (a version this reader knows), validated against the schema of docs/lut-format.md
    before its pixels are read (lutbake/tables/headers.py); ValueError names the file and the field."""
    path = Path(path)
    if not path.is_file():  # also refuses FIFOs and devices, which could block a read forever
        raise ValueError(f"LUT {str(path)!r} does not exist or is not a file")
    journal = fileset.pending_commit(path)
    if journal is not None:
        raise ValueError(
            f"{str(path)!r} is mid-commit ({journal.name}: a bake was interrupted or is running): bake it again"
        )
    try:
        structure = check_structure(exr_header(path))
    except (OSError, ValueError, struct.error) as exc:
        raise ValueError(f"{str(path)!r} is not a lutbake EXR: {exc}") from None
    meta = load_json(structure["metadata"], f"{str(path)!r}: lutbake.metadata")
    if (
        not isinstance(meta, dict)
        or not isinstance(meta.get("format"), str)
        or meta["format"] not in formats
        or not _integer(meta.get("format_version"))
        or meta["format_version"] not in _READABLE_VERSIONS[meta["format"]]
    ):
        known = " or ".join(f"{f} v{'/'.join(map(str, _READABLE_VERSIONS[f]))}" for f in formats)
        raise ValueError(f"{str(path)!r} is not a {known} file")
    try:
        check_metadata(meta, structure)
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: metadata field {exc} is missing or invalid") from None
    image = _read_pixels(path, structure)
    if not np.isfinite(image).all():
        raise ValueError(f"{str(path)!r}: image holds non-finite texels (NaN or Inf): bake it again")
    return meta, image


def _read_pixels(path: Path, structure: dict) -> np.ndarray:
    """The RGB image of an EXR whose header passed ``check_structure``; OpenEXR's own messages are silenced."""
    import OpenEXR

    try:
        with _silenced_c_output(), OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if "RGB" in channels:
                image = np.array(channels["RGB"].pixels)
            else:
                image = np.stack([np.array(channels[c].pixels) for c in "RGB"], axis=-1)
    except Exception:  # OpenEXR raises several types for damaged files; all mean the same here
        raise ValueError(f"{str(path)!r} is not a readable EXR (damaged or truncated)") from None
    if image.shape != (structure["height"], structure["width"], 3) or image.dtype.kind != "f":
        raise ValueError(f"{str(path)!r} is not a readable EXR (pixels do not match its header)")
    return image


@contextlib.contextmanager
def _silenced_c_output():
    """Send file descriptors 1 and 2 and sys.stdout/stderr nowhere (OpenEXR prints warnings). A descriptor
    that was closed (`lutbake inspect X >&-`) is closed again afterwards."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved = [_dup_or_none(1), _dup_or_none(2)]
    opened = os.open(os.devnull, os.O_WRONLY)  # the lowest free descriptor: 1 or 2 if closed
    null = fcntl.fcntl(opened, fcntl.F_DUPFD, 3)
    os.close(opened)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            yield  # the bindings also print through Python's sys.stdout
    finally:
        _libc_fflush()  # C++ streams buffered while redirected must drain into /dev/null
        for fd, old in ((1, saved[0]), (2, saved[1])):
            if old is None:
                os.close(fd)
            else:
                os.dup2(old, fd)
                os.close(old)
        os.close(null)


def _dup_or_none(fd: int):
    try:
        return fcntl.fcntl(fd, fcntl.F_DUPFD, 3)
    except OSError:  # closed
        return None


def _libc_fflush() -> None:
    import ctypes

    ctypes.CDLL(None).fflush(None)


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def shader_includes(meta: dict, lut_name: str) -> dict:
    """GLSL and HLSL include texts for a LUT, keyed by file suffix."""
    axes = meta["axes"]
    warn_texture_size(meta["packing"]["width"], meta["packing"]["height"], lut_name)
    fields = {
        "lut_name": shader_comment(lut_name),
        "ident": shader_ident(Path(lut_name).stem),
        "content_hash": meta["content_hash"],
        "eta1": repr(meta["constants"]["eta1"]),
        "eta2": repr(meta["constants"]["eta2"]),
        "eta1_f": _shader_float(meta["constants"]["eta1"]),
        "eta2_f": _shader_float(meta["constants"]["eta2"]),
        "space": meta["space"],
        "min": ", ".join(_shader_float(a["min"]) for a in axes),
        "max": ", ".join(_shader_float(a["max"]) for a in axes),
        "count": ", ".join(_shader_float(a["count"]) for a in axes),
        "sqrt": ", ".join("1.0" if a["spacing"] in ("sqrt", "sqrt-admittance") else "0.0" for a in axes),
        "root4": ", ".join(
            "1.0"
            if a["spacing"] == "root4"
            else _shader_float(ROOT4_WEIGHT)
            if a["spacing"] == "uniform-root4"
            else "0.0"
            for a in axes
        ),
        "mirror": ", ".join(
            "1.0" if mirrors_low_end(a["spacing"], a["min"], any("corner" in b for b in axes)) else "0.0" for a in axes
        ),
        "admittance": "1.0" if axes[2]["spacing"] in ADMITTANCE_SPACINGS else "0.0",
        "corner_share": ", ".join(
            _shader_float(a["corner"]["nodes"] / (a["count"] - 1)) if "corner" in a else "0.0" for a in axes
        ),
        "corner_scale": ", ".join(_shader_float(a["corner"]["scale"]) if "corner" in a else "1.0" for a in axes),
        "tiles_x_kappa3": "1.0" if meta["packing"]["tiles_x"] == "kappa3" else "0.0",
        "interpolation": meta.get("interpolation", "linear"),
        "cubic": "1.0" if meta.get("interpolation") == "cubic" else "0.0",
    }
    return {suffix: shader_template(f"lutbake.{suffix}.in").substitute(fields) for suffix in ("glsl", "hlsl")}


def shader_template(name: str) -> string.Template:
    return string.Template(resources.files("lutbake").joinpath(f"shaders/{name}").read_text())


def warn_texture_size(width: int, height: int, name: str) -> None:
    """Warn when an image exceeds what many GPUs load (docs/engines.md: texture size)."""
    if max(width, height) > MAX_TEXTURE_SIZE:
        warnings.warn(
            f"{name}: {width}×{height} texels exceeds {MAX_TEXTURE_SIZE} in a dimension; many "
            f"GPUs cannot load it (WebGL2 guarantees 2048, mobile GPUs 4096)",
            stacklevel=2,
        )


def _shader_float(value) -> str:
    text = repr(float(value))
    return text if ("e" in text or "." in text) else text + ".0"
