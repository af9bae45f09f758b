"""The LUT file: a self-describing EXR, a JSON sidecar, GLSL and HLSL includes.

The EXR holds R, G, B (float32 or half, ZIP compression, which every
OpenEXR 3.x reader decodes) in the tile packing of plan.py. Metadata go in
string attributes: ``lutbake.metadata`` holds the whole description as JSON
(doubles written with Python's shortest round-trip repr, so they come back
bit-exact; a plain float attribute would be stored as 32-bit), and flat
``lutbake.*`` attributes repeat the key fields for tools such as
``oiiotool --info -v``. docs/lut-format.md specifies it for engine authors.

A LUT's four files are one set (fileset.py): written as hidden temporaries,
then committed together, so an interrupted or failed bake leaves the
previous set (or none), never a partial or mixed one. Nothing time- or machine-dependent is written:
the same inputs give the same bytes.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import string
import sys
import warnings
from importlib import resources
from pathlib import Path

import numpy as np

from . import fileset
from .fileset import temporary_for
from .interpolation import mirrors_low_end
from .names import ADMITTANCE_SPACINGS, INTERPOLATIONS
from .layout import TileLayout

__all__ = ["FORMAT", "ATLAS_FORMAT", "EXACT_FORMAT", "FORMAT_VERSION", "EXACT_FORMAT_VERSION", "exr_rows", "exr_stream", "read_lut",
           "write_atlas", "write_text_atomic", "atomic_path", "shader_includes",
           "shader_ident", "shader_template", "flat_attributes", "MAX_TEXTURE_SIZE"]

FORMAT = "lutbake-lut"
ATLAS_FORMAT = "lutbake-atlas"  # a scene's 2D slices (atlas.py, write_atlas)
EXACT_FORMAT = "lutbake-exact"  # the exact runtime mode's colour-weight transform table (exact.py)
# LUT v2 adds the η3 axis's "admittance" spacing, v3 "root4" and the "interpolation" key, v4 the η3 axis's
# "sqrt-admittance" spacing (docs/lut-format.md); older LUTs (no such axis) still read.
FORMAT_VERSION = 4
EXACT_FORMAT_VERSION = 1
_READABLE_VERSIONS = {FORMAT: (1, 2, 3, 4), ATLAS_FORMAT: (1,), EXACT_FORMAT: (EXACT_FORMAT_VERSION,)}
_ADMITTANCE_SINCE = dict(zip(ADMITTANCE_SPACINGS, (2, 4)))   # η3 spacing → first format version with it
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
                out.update(flat_attributes({k: v for k, v in item.items() if k not in ("name", "id")},
                                           f"{name}.{label}"))
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
    one of ``formats`` (a version this reader knows), validated against the schema of docs/lut-format.md;
    ValueError names the file and the field."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"LUT {str(path)!r} does not exist")
    if fileset.journal_path(path.parent, path.name).exists():
        raise ValueError(f"{str(path)!r} is mid-commit (a bake was interrupted or is running): bake it again")
    meta_text, image = _read_exr(path)
    try:
        meta = json.loads(meta_text)
    except ValueError:
        raise ValueError(f"{str(path)!r}: lutbake.metadata is not JSON") from None
    if (not isinstance(meta, dict) or meta.get("format") not in formats
            or meta.get("format_version") not in _READABLE_VERSIONS[meta["format"]]):
        known = " or ".join(f"{f} v{'/'.join(map(str, _READABLE_VERSIONS[f]))}" for f in formats)
        raise ValueError(f"{str(path)!r} is not a {known} file")
    try:
        {FORMAT: _check_meta, ATLAS_FORMAT: _check_atlas_meta, EXACT_FORMAT: _check_exact_meta}[meta["format"]](
            meta, image)
    except (KeyError, TypeError, ValueError) as exc:
        field = exc.args[0] if exc.args else "?"
        raise ValueError(f"{str(path)!r}: metadata field {field} is missing or invalid") from None
    return meta, image


def _read_exr(path: Path):
    """(lutbake.metadata text, RGB image) of an EXR; OpenEXR's own messages are silenced."""
    import OpenEXR

    try:
        with _silenced_c_output(), OpenEXR.File(str(path)) as exr:
            header, channels = exr.header(), exr.channels()
            if "lutbake.metadata" not in header:
                raise LookupError("lutbake.metadata")
            meta_text = header["lutbake.metadata"]
            if "RGB" in channels:
                image = np.array(channels["RGB"].pixels)
            else:
                image = np.stack([np.array(channels[c].pixels) for c in "RGB"], axis=-1)
    except LookupError:
        raise ValueError(f"{str(path)!r} is an EXR without lutbake metadata or RGB channels") from None
    except Exception:  # OpenEXR raises several types for damaged files; all mean the same here
        raise ValueError(f"{str(path)!r} is not a readable EXR (damaged or truncated)") from None
    return meta_text, image


@contextlib.contextmanager
def _silenced_c_output():
    """Send file descriptors 1 and 2 and sys.stdout/stderr nowhere (OpenEXR prints warnings)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            yield  # the bindings also print through Python's sys.stdout
    finally:
        _libc_fflush()  # C++ streams buffered while redirected must drain into /dev/null
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


def _libc_fflush() -> None:
    import ctypes

    ctypes.CDLL(None).fflush(None)


_AXES = ("cos_theta", "opd_nm", "eta3", "kappa3")
_STRINGS = ("lutbake_version", "content_hash", "observer", "illuminant", "space", "precision", "compute")


def _check_meta(meta: dict, image: np.ndarray) -> None:
    """Raise KeyError/TypeError/ValueError with the field name when ``meta`` breaks the schema."""
    for key in _STRINGS:
        _require(isinstance(meta[key], str), key)
    axes = meta["axes"]
    _require(isinstance(axes, list) and [a["name"] for a in axes] == list(_AXES), "axes")
    for i, a in enumerate(axes):
        lo, hi = _finite(a["min"], f"axes[{i}].min"), _finite(a["max"], f"axes[{i}].max")
        _require(hi > lo, f"axes[{i}].max")
        _require(_integer(a["count"]) and 2 <= a["count"] <= 1 << 24, f"axes[{i}].count")
        _require(a["spacing"] in ("uniform", "sqrt") and (a["spacing"] == "uniform" or lo >= 0)
                 or a["spacing"] == "root4" and lo >= 0 and meta["format_version"] >= 3
                 or a["spacing"] in _ADMITTANCE_SINCE and a["name"] == "eta3"
                 and meta["format_version"] >= _ADMITTANCE_SINCE[a["spacing"]]
                 and lo >= meta["constants"]["eta1"], f"axes[{i}].spacing")
    _require(meta["format_version"] < 3 or meta["interpolation"] in INTERPOLATIONS, "interpolation")
    packing, expected = meta["packing"], TileLayout(*(a["count"] for a in axes)).packing()
    for key in ("width", "height", "tile_width", "tile_height"):
        _require(packing[key] == expected[key], f"packing.{key}")
    _require(image.shape == (packing["height"], packing["width"], 3), "packing (image size)")
    for key in ("eta1", "eta2"):
        _require(_finite(meta["constants"][key], f"constants.{key}") > 0, f"constants.{key}")
    spectral = meta["spectral"]
    _require(isinstance(spectral["counts"], list) and len(spectral["counts"]) > 0, "spectral.counts")
    _finite(spectral["error_rgb_max"], "spectral.error_rgb_max")
    _require(bool(np.isfinite(image).all()), "image (non-finite texels)")


def _check_atlas_meta(meta: dict, image: np.ndarray) -> None:
    """The atlas schema (docs/lut-format.md): slices whose rects lie in the image, named materials,
    a finite thickness range and ambient index."""
    _require(_finite(meta["eta1"], "eta1") > 0, "eta1")
    height, width, _ = image.shape
    _require(isinstance(meta["slices"], list) and len(meta["slices"]) > 0, "slices")
    for i, s in enumerate(meta["slices"]):
        x0, y0, w, h = s["rect"]
        _require(all(_integer(v) for v in (x0, y0, w, h)) and x0 >= 0 and y0 >= 0 and w >= 2 and h >= 1
                 and x0 + w <= width and y0 + h <= height, f"slices[{i}].rect")
        _require(isinstance(s["materials"], list) and all(isinstance(m, str) and m for m in s["materials"]),
                 f"slices[{i}].materials")
        th = s["axes"]["thickness_nm"]
        _require(_finite(th["max"], f"slices[{i}].axes.thickness_nm.max")
                 >= _finite(th["min"], f"slices[{i}].axes.thickness_nm.min"), f"slices[{i}].axes.thickness_nm")
    _require(bool(np.isfinite(image).all()), "image (non-finite texels)")


def _check_exact_meta(meta: dict, image: np.ndarray) -> None:
    """The exact table's schema (docs/lut-format.md): its layout matches the image, finite bounds."""
    table = meta["table"]
    _require(_finite(table["step_nm"], "table.step_nm") > 0, "table.step_nm")
    _require(_integer(table["width"]) and _integer(table["rows_per_part"]) and _integer(table["texels"])
             and table["texels"] == table["width"] * table["rows_per_part"] >= 2, "table.texels")
    _require(image.shape == (2 * table["rows_per_part"], table["width"], 3), "table (image size)")
    _finite(table["nu0_per_nm"], "table.nu0_per_nm")
    for key in ("mass", "edge", "variation"):
        _require(_finite(meta["tail"][key], f"tail.{key}") >= 0, f"tail.{key}")
    _require(0 < _finite(meta["include"]["tolerance"], "include.tolerance") < 1, "include.tolerance")
    _require(_integer(meta["include"]["max_terms"]) and meta["include"]["max_terms"] >= 1, "include.max_terms")
    _require(bool(np.isfinite(image).all()), "image (non-finite texels)")


def _require(ok: bool, field: str) -> None:
    if not ok:
        raise ValueError(field)


def _integer(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _finite(value, field: str) -> float:
    _require(isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value), field)
    return float(value)


def shader_includes(meta: dict, lut_name: str) -> dict:
    """GLSL and HLSL include texts for a LUT, keyed by file suffix."""
    axes = meta["axes"]
    warn_texture_size(meta["packing"]["width"], meta["packing"]["height"], lut_name)
    fields = {
        "lut_name": lut_name,
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
        "root4": ", ".join("1.0" if a["spacing"] == "root4" else "0.0" for a in axes),
        "mirror": ", ".join("1.0" if mirrors_low_end(a["spacing"], a["min"]) else "0.0" for a in axes),
        "admittance": "1.0" if axes[2]["spacing"] in _ADMITTANCE_SINCE else "0.0",
        "interpolation": meta.get("interpolation", "linear"),
        "cubic": "1.0" if meta.get("interpolation") == "cubic" else "0.0",
    }
    return {suffix: shader_template(f"lutbake.{suffix}.in").substitute(fields) for suffix in ("glsl", "hlsl")}


def shader_template(name: str) -> string.Template:
    return string.Template(resources.files("lutbake").joinpath(f"shaders/{name}").read_text())


def shader_ident(name: str) -> str:
    """A shader constant name for a LUT or material: LUTBAKE_ + its name in upper case, _ for the rest."""
    ident = "".join(c if c.isalnum() else "_" for c in name).upper()
    return ident if ident.startswith("LUTBAKE_") else f"LUTBAKE_{ident}"


def warn_texture_size(width: int, height: int, name: str) -> None:
    """Warn when an image exceeds what many GPUs load (docs/engines.md: texture size)."""
    if max(width, height) > MAX_TEXTURE_SIZE:
        warnings.warn(f"{name}: {width}×{height} texels exceeds {MAX_TEXTURE_SIZE} in a dimension; many "
                      f"GPUs cannot load it (WebGL2 guarantees 2048, mobile GPUs 4096)", stacklevel=2)


def _shader_float(value) -> str:
    text = repr(float(value))
    return text if ("e" in text or "." in text) else text + ".0"
