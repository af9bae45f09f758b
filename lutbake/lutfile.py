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
import json
import os
import signal
import string
from importlib import resources
from pathlib import Path

import numpy as np

from .fileset import main_thread, raise_interrupt, temporary_for

__all__ = ["FORMAT", "FORMAT_VERSION", "exr_rows", "exr_stream", "read_lut", "write_text_atomic",
           "atomic_path", "shader_includes", "flat_attributes"]

FORMAT = "lutbake-lut"
FORMAT_VERSION = 1


@contextlib.contextmanager
def atomic_path(final: Path):
    """Yield a temporary path beside ``final``; rename it into place on success.

    SIGTERM is turned into an exception for the duration so the temporary is
    removed on the way out (kill -9 leaves only the hidden temporary, which the
    next bake into the folder removes). Single files only: a LUT or scene file
    set is committed as one unit by fileset.open_set.
    """
    final = Path(final)
    tmp = temporary_for(final)
    previous = signal.getsignal(signal.SIGTERM)
    if main_thread():
        signal.signal(signal.SIGTERM, raise_interrupt)
    try:
        yield tmp
        os.replace(tmp, final)
    finally:
        if main_thread():
            signal.signal(signal.SIGTERM, previous)
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


def read_lut(path):
    """(metadata dict, image array (height, width, 3) as stored) of a lutbake EXR."""
    import OpenEXR

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"LUT {str(path)!r} does not exist")
    try:
        with OpenEXR.File(str(path)) as exr:
            header = exr.header()
            channels = exr.channels()
            if "lutbake.metadata" not in header:
                raise ValueError(f"{str(path)!r} is an EXR without lutbake metadata")
            meta = json.loads(header["lutbake.metadata"])
            if "RGB" in channels:
                image = np.array(channels["RGB"].pixels)
            else:
                image = np.stack([np.array(channels[c].pixels) for c in "RGB"], axis=-1)
    except (OSError, RuntimeError) as exc:
        raise ValueError(f"{str(path)!r} is not a readable EXR: {exc}") from None
    if meta.get("format") != FORMAT or meta.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{str(path)!r} is not a {FORMAT} v{FORMAT_VERSION} file")
    return meta, image


def shader_includes(meta: dict, lut_name: str) -> dict:
    """GLSL and HLSL include texts for a LUT, keyed by file suffix."""
    axes = meta["axes"]
    fields = {
        "lut_name": lut_name,
        "content_hash": meta["content_hash"],
        "eta1": repr(meta["constants"]["eta1"]),
        "eta2": repr(meta["constants"]["eta2"]),
        "space": meta["space"],
        "min": ", ".join(_shader_float(a["min"]) for a in axes),
        "max": ", ".join(_shader_float(a["max"]) for a in axes),
        "count": ", ".join(_shader_float(a["count"]) for a in axes),
        "sqrt": ", ".join("1.0" if a["spacing"] == "sqrt" else "0.0" for a in axes),
    }
    out = {}
    for suffix in ("glsl", "hlsl"):
        template = resources.files("lutbake").joinpath(f"shaders/lutbake.{suffix}.in").read_text()
        out[suffix] = string.Template(template).substitute(fields)
    return out


def _shader_float(value) -> str:
    text = repr(float(value))
    return text if ("e" in text or "." in text) else text + ".0"
