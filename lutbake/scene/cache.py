"""The scene cache (OUT/.lutbake-cache): what each computed job yielded, keyed by the job's content
hash, so a re-bake recomputes only the jobs that changed (docs/scene.md, Incremental).

Nothing in it is trusted: a slice's entry is ``JOB.npy`` (its float64 values) and ``JOB.json`` (its
record: counts, p99 and bound reached, the searched max, the .npy's SHA-256). The record is read with
bounded size and nesting (lutbake/io/documents.py); the .npy's header is read first and its shape, dtype
and size checked against the record's counts before any array is allocated; the bytes must hash to the
recorded SHA-256 (a zeroed or foreign .npy of the right shape is not reused) and be finite. A 4D job's record holds its
LUT EXR's SHA-256, checked against the file in the output folder. Any failure means "recompute".
"""

from __future__ import annotations

import hashlib
import io
import json
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.io.documents import load_json, read_text
from lutbake.io.fileset import sha256_file
from lutbake.tables.lutfile import atomic_path, write_text_atomic

if TYPE_CHECKING:
    from lutbake.scene.plan import SceneJob

__all__ = ["SceneCache", "MAX_RECORD_BYTES"]

# A record is a few hundred bytes; anything near this is not one lutbake wrote.
MAX_RECORD_BYTES = 1 << 16
_NOT_USABLE = (OSError, ValueError, EOFError, KeyError, TypeError)


class SceneCache:
    """The cache folder of one output folder; ``slice``/``lut`` return None for anything not usable."""

    def __init__(self, out: Path | str):
        self.folder = Path(out) / ".lutbake-cache"

    def paths(self, job: SceneJob) -> tuple[Path, Path]:
        return self.folder / f"{job.id}.npy", self.folder / f"{job.id}.json"

    def slice(self, job: SceneJob) -> tuple[np.ndarray, dict[str, Any]] | None:
        """(values, record) of the job's slice entry when every check passes, else None."""
        npy, info = self.paths(job)
        try:
            record = _record(info)
            n_cos, n_d = record["counts"]
            values = _read_npy(npy, (n_d, n_cos, 3), record["sha256"])
        except _NOT_USABLE:
            return None
        return (values, record) if np.isfinite(values).all() else None

    def store_slice(self, job: SceneJob, values: np.ndarray, record: dict[str, Any]) -> dict[str, Any]:
        """Write the slice's values and record (with the .npy's SHA-256); return the record."""
        self.folder.mkdir(exist_ok=True)
        npy, info = self.paths(job)
        buffer = io.BytesIO()
        np.save(buffer, np.ascontiguousarray(values, dtype=np.float64))
        with atomic_path(npy) as tmp:
            tmp.write_bytes(buffer.getvalue())
        record = {**record, "sha256": hashlib.sha256(buffer.getvalue()).hexdigest()}
        write_text_atomic(info, json.dumps(record, indent=2) + "\n")
        return record

    def lut(self, job: SceneJob, exr: Path, members: Iterable[Path]) -> dict[str, Any] | None:
        """The record of a 4D job whose LUT set (``members``) is complete and whose EXR has the
        recorded hash, else None."""
        try:
            record = _record(self.paths(job)[1])
            ok = all(p.is_file() for p in members) and sha256_file(exr) == record["sha256"]
        except _NOT_USABLE:
            return None
        return record if ok else None

    def store_lut(self, job: SceneJob, record: dict[str, Any]) -> None:
        self.folder.mkdir(exist_ok=True)
        write_text_atomic(self.paths(job)[1], json.dumps(record, indent=2) + "\n")


def _record(path: Path) -> dict[str, Any]:
    """A cache record with integer counts, finite errors (p99, its bound, the searched max), whether the
    target was met, where the max is, and a SHA-256; raises otherwise."""
    info = load_json(read_text(path, "cache record", MAX_RECORD_BYTES), str(path))
    info["counts"] = [int(c) for c in info["counts"]]
    errors = (float(info[k]) for k in ("de00_p99", "de00_p99_bound", "de00_max"))
    if (
        not all(np.isfinite(e) for e in errors)
        or not isinstance(info["target_met"], bool)
        or not isinstance(info["worst_case"], dict)
        or not isinstance(info["sha256"], str)
    ):
        raise ValueError("cache record")
    return info


def _read_npy(path: Path, shape: tuple[int, ...], sha256: str) -> np.ndarray:
    """The float64 array of ``shape`` in ``path``, refused (ValueError) before it is read when the
    header declares another shape, dtype or order, or the file's size does not match it, and after
    it is read when its bytes do not hash to ``sha256``."""
    fmt = np.lib.format
    size = path.stat().st_size
    with open(path, "rb") as fh:
        version = fmt.read_magic(fh)
        read_header = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        declared, fortran, dtype = read_header(fh, max_header_size=1024)
        if declared != shape or fortran or dtype != np.dtype("<f8"):
            raise ValueError("cache entry header")
        if size != fh.tell() + 8 * int(np.prod(shape)):
            raise ValueError("cache entry size")
        fh.seek(0)
        data = fh.read(size)
    if hashlib.sha256(data).hexdigest() != sha256:
        raise ValueError("cache entry hash")
    return np.load(io.BytesIO(data), allow_pickle=False)
