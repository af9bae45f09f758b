"""A table's files: the self-describing EXR, its JSON sidecar and its GLSL and HLSL includes, written as one
set and read back through one bounded reader, for every table kind (tables/headers.py: KINDS).

The EXR is authoritative (tables/exr.py); NAME.json repeats its metadata (a LUT's adds where it was baked),
NAME.glsl and NAME.hlsl are rendered from it (tables/includes.py). The four files are one set
(lutbake/io/fileset.py): written as hidden temporaries, then committed together, so an interrupted or failed
write leaves the previous set (or none), never a partial or mixed one. docs/lut-format.md specifies the
files for engine authors.

``read_lut`` reads any kind: the header is parsed and checked, structure then metadata against its kind's
schema, before the pixels are read, and the pixel read is sized by that checked header.
"""

from __future__ import annotations

import contextlib
import json
import os
import struct
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from lutbake.io import fileset
from lutbake.io.documents import load_json
from lutbake.io.fileset import FileSet, open_set, temporary_for
from lutbake.tables.exr import ExrRows, exr_rows, read_pixels, write_image
from lutbake.tables.headers import FORMAT, KINDS, check_metadata, check_structure, exr_header
from lutbake.tables.includes import shader_includes

__all__ = [
    "read_lut",
    "write_table_set",
    "write_companions",
    "exr_stream",
    "atomic_path",
    "write_text_atomic",
]


@contextlib.contextmanager
def atomic_path(final: Path) -> Iterator[Path]:
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


@contextlib.contextmanager
def exr_stream(path: Path, width: int, height: int, meta: dict, precision: str = "float") -> Iterator[ExrRows]:
    """exr_rows into a temporary: the file appears only when complete."""
    with atomic_path(path) as tmp, exr_rows(tmp, width, height, meta, precision) as rows:
        yield rows


def write_companions(files: FileSet, out_path: Path, meta: dict, sidecar: dict | None = None) -> None:
    """Into temporaries of ``files``: the EXR ``out_path``'s sidecar NAME.json (``sidecar``, else its header
    ``meta``) and its includes NAME.glsl and NAME.hlsl."""
    text = json.dumps(meta if sidecar is None else sidecar, indent=2, sort_keys=True) + "\n"
    files.temp(out_path.with_suffix(".json")).write_text(text)
    for suffix, include in shader_includes(meta, out_path.name).items():
        files.temp(out_path.with_suffix(f".{suffix}")).write_text(include)


def write_table_set(out_path: Path, image: np.ndarray, meta: dict, precision: str) -> None:
    """Write a whole table, ``image`` under the header ``meta``, with its sidecar and includes as one set."""
    with open_set(out_path.parent, out_path.name) as files:
        write_image(files.temp(out_path), image, meta, precision)
        write_companions(files, out_path, meta)


def read_lut(path: str | os.PathLike, formats: tuple = (FORMAT,)) -> tuple[dict, np.ndarray]:
    """(metadata dict, image array (height, width, channels) as stored) of a lutbake EXR whose format is
    one of ``formats`` (a version this reader knows), validated against the schema of docs/lut-format.md
    before its pixels are read (lutbake/tables/headers.py); ValueError names the file and the field."""
    path = Path(path)
    kinds = [KINDS[f] for f in formats]
    if not path.is_file():  # also refuses FIFOs and devices, which could block a read forever
        raise ValueError(f"{kinds[0].noun} {str(path)!r} does not exist or is not a file")
    journal = fileset.pending_commit(path)
    if journal is not None:
        raise ValueError(
            f"{str(path)!r} is mid-commit ({journal.name}: a bake was interrupted or is running): bake it again"
        )
    try:
        structure = check_structure(exr_header(path), tuple(dict.fromkeys(k.channels for k in kinds)))
    except (OSError, ValueError, struct.error) as exc:
        raise ValueError(f"{str(path)!r} is not a {kinds[0].title}: {exc}") from None
    meta = load_json(structure["metadata"], f"{str(path)!r}: lutbake.metadata")
    if (
        not isinstance(meta, dict)
        or not isinstance(meta.get("format"), str)
        or meta["format"] not in formats
        or not _integer(meta.get("format_version"))
        or meta["format_version"] not in KINDS[meta["format"]].versions
    ):
        known = " or ".join(f"{f} v{'/'.join(map(str, KINDS[f].versions))}" for f in formats)
        raise ValueError(f"{str(path)!r} is not a {known} file")
    try:
        check_metadata(meta, structure)
    except ValueError as exc:
        raise ValueError(f"{str(path)!r}: metadata field {exc} is missing or invalid") from None
    image = read_pixels(path, structure)
    if not np.isfinite(image).all():
        raise ValueError(f"{str(path)!r}: image holds non-finite texels (NaN or Inf): bake it again")
    return meta, image


def _integer(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)
