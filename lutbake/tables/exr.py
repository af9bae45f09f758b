"""Pixel rows in and out of a lutbake EXR: the one writer and the bounded pixel read of every table kind.

A table's EXR holds R, G, B (R, G, B, A for the runtime table) as float32 or half, ZIP-compressed, which
every OpenEXR 3.x reader decodes. Metadata go in string attributes: ``lutbake.metadata`` holds the whole
description as JSON (doubles written with Python's shortest round-trip repr, so they come back bit-exact; a
plain float attribute would be stored as 32-bit), and flat ``lutbake.*`` attributes repeat the key fields for
tools such as ``oiiotool --info -v``. Nothing time- or machine-dependent is written: the same inputs give the
same bytes.

OpenEXR compresses the blocks of 16 rows in its own thread pool, sized here to the cores this process may
run on (``usable_cores``): its Python binding holds the interpreter while it writes, so a writer
thread in Python would not overlap anything, but the pool's threads do, and each block is compressed alike
on any number of them (the bytes do not depend on the thread count: tests/tables/test_table_files.py).

``exr_rows`` streams bands of rows in order (a bake's LUT in bounded memory); ``write_image`` writes a whole
image (an atlas, the exact and runtime tables). ``read_pixels`` reads the image of a file whose header
tables/headers.py has already checked (lutfile.read_lut does both, in that order), so OpenEXR allocates
only what that header declares, which its size bounds.
"""

from __future__ import annotations

import contextlib
import fcntl
import io
import json
import os
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from lutbake.io.cores import usable_cores

__all__ = ["ExrRows", "exr_rows", "write_image", "read_pixels", "flat_attributes"]


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


class ExrRows:
    """An open EXR receiving bands of rows in order: ``channels`` ("RGB" or "RGBA") of ``precision``
    ('half' or 'float') texels, compressed on ``threads`` of OpenEXR's pool (None: usable_cores();
    0: on the writing thread alone)."""

    def __init__(
        self,
        path: Path,
        width: int,
        height: int,
        meta: dict,
        precision: str,
        channels: str = "RGB",
        threads: int | None = None,
    ):
        import Imath
        import OpenEXR

        threads = usable_cores() if threads is None else threads
        if OpenEXR.global_thread_count() != threads:  # the pool is the process's: resized only when it differs
            OpenEXR.set_global_thread_count(threads)

        self.height = height
        self.channels = channels
        self.dtype = np.float16 if precision == "half" else np.float32
        pixel = Imath.PixelType(Imath.PixelType.HALF if precision == "half" else Imath.PixelType.FLOAT)
        header = OpenEXR.Header(width, height)
        header["channels"] = {c: Imath.Channel(pixel) for c in channels}
        header["compression"] = Imath.Compression(Imath.Compression.ZIP_COMPRESSION)
        header["lutbake.metadata"] = json.dumps(meta, sort_keys=True).encode()
        for key, value in flat_attributes(meta).items():
            header[key] = value.encode()
        self.file = OpenEXR.OutputFile(str(path), header)
        self.rows_written = 0

    def write_rows(self, rows: np.ndarray) -> np.ndarray:
        """Append a band (rows, width, channels); return it as stored (rounded to the file's precision)."""
        stored = np.ascontiguousarray(rows, dtype=self.dtype)
        planes = {c: np.ascontiguousarray(stored[:, :, i]).tobytes() for i, c in enumerate(self.channels)}
        self.file.writePixels(planes, stored.shape[0])
        self.rows_written += stored.shape[0]
        return stored


@contextlib.contextmanager
def exr_rows(
    path: Path,
    width: int,
    height: int,
    meta: dict,
    precision: str = "float",
    channels: str = "RGB",
    threads: int | None = None,
) -> Iterator[ExrRows]:
    """Write an EXR at ``path`` band by band (bounded memory) on ``threads`` (ExrRows); raise if left
    incomplete."""
    rows = ExrRows(path, width, height, meta, precision, channels, threads)
    try:
        yield rows
    finally:
        rows.file.close()
    if rows.rows_written != height:
        raise RuntimeError(f"LUT incomplete: {rows.rows_written} of {height} rows written")


def write_image(path: Path, image: np.ndarray, meta: dict, precision: str) -> None:
    """Write a whole image (height, width, 3 or 4: R, G, B and A) with its header ``meta``."""
    height, width, channels = image.shape
    with exr_rows(path, width, height, meta, precision, "RGBA"[:channels]) as exr:
        exr.write_rows(image)


def read_pixels(path: Path, structure: dict) -> np.ndarray:
    """The image (height, width, channels) of an EXR whose header passed ``headers.check_structure``
    (``structure`` is what it returned); OpenEXR's own messages are silenced. ValueError when the pixels
    are damaged or do not match that header."""
    import OpenEXR

    names = structure["channels"]
    try:
        with _silenced_c_output(), OpenEXR.File(str(path)) as exr:
            channels = exr.channels()
            if names in channels:
                image = np.array(channels[names].pixels)
            else:
                image = np.stack([np.array(channels[c].pixels) for c in names], axis=-1)
    except Exception:  # OpenEXR raises several types for damaged files; all mean the same here
        raise ValueError(f"{str(path)!r} is not a readable EXR (damaged or truncated)") from None
    if image.shape != (structure["height"], structure["width"], len(names)) or image.dtype.kind != "f":
        raise ValueError(f"{str(path)!r} is not a readable EXR (pixels do not match its header)")
    return image


@contextlib.contextmanager
def _silenced_c_output() -> Iterator[None]:
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


def _dup_or_none(fd: int) -> int | None:
    try:
        return fcntl.fcntl(fd, fcntl.F_DUPFD, 3)
    except OSError:  # closed
        return None


def _libc_fflush() -> None:
    import ctypes

    ctypes.CDLL(None).fflush(None)
