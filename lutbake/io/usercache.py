"""Arrays computed once per machine, kept in the user's cache folder.

$LUTBAKE_CACHE_DIR, else $XDG_CACHE_HOME/lutbake, else ~/.cache/lutbake
(created private). Entries are named by a hash of everything they depend on
and written atomically. Nothing in the folder is trusted: an entry is used
only when every array's stored header declares the expected shape and a
numeric dtype (checked before anything is allocated, so an entry declaring
an 8 TB array costs nothing), its values are finite, and the SHA-256 stored
with the arrays matches their bytes; anything else is rebuilt. Without a
writable folder (a file where it goes, a read-only folder) each process
rebuilds what it needs; nothing else changes.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from pathlib import Path

import numpy as np

__all__ = ["cached_arrays"]

_HASH = "sha256"  # the member holding the SHA-256 of the other arrays


def _cache_home() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def _usable_folder(folder: Path, mode: int = 0o700) -> bool:
    """``folder`` exists (created if need be) and this process may create files in it."""
    try:
        folder.mkdir(mode=mode, parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def _folder() -> Path | None:
    folder = Path(os.environ.get("LUTBAKE_CACHE_DIR") or _cache_home() / "lutbake")
    return folder if _usable_folder(folder) else None


def _digest(arrays: dict) -> np.ndarray:
    """SHA-256 over each array's name, dtype, shape and bytes, in name order, as 32 uint8."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        digest.update(a.tobytes())
    return np.frombuffer(digest.digest(), dtype=np.uint8)


def _declared(archive: zipfile.ZipFile, name: str) -> tuple:
    """(shape, dtype) an .npy member of ``archive`` declares, read from its header alone."""
    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    with archive.open(f"{name}.npy") as member:
        version = np.lib.format.read_magic(member)
        if version not in readers:
            raise ValueError(f"npy format version {version}")
        shape, _, dtype = readers[version](member)
    return shape, dtype


def _load(path: Path, shapes: dict) -> dict | None:
    """The arrays of the entry at ``path`` when it passes every check of the module docstring, else None."""
    expected = {**shapes, _HASH: (32,)}
    try:
        with zipfile.ZipFile(path) as archive:
            for name, shape in expected.items():
                declared_shape, dtype = _declared(archive, name)
                if declared_shape != tuple(shape) or dtype.kind not in ("u" if name == _HASH else "fc"):
                    return None
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in shapes}
            stored_hash = stored[_HASH]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None
    if not all(np.isfinite(a).all() for a in arrays.values()):
        return None
    return arrays if np.array_equal(stored_hash, _digest(arrays)) else None


def _save(path: Path, arrays: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays, **{_HASH: _digest(arrays)})
        os.replace(tmp, path)
    except OSError:  # a read-only or full cache folder costs a rebuild next time, nothing else
        tmp.unlink(missing_ok=True)


def cached_arrays(kind: str, key: bytes, shapes: dict, build) -> dict:
    """The arrays ``build()`` returns (name → array of ``shapes[name]``), from the cache entry for
    (``kind``, ``key``) when it is valid, else built now and stored."""
    folder = _folder()
    path = folder / f"{kind}-{hashlib.sha256(key).hexdigest()[:24]}.npz" if folder else None
    arrays = _load(path, shapes) if path else None
    if arrays is None:
        arrays = build()
        if path:
            _save(path, arrays)
    return arrays
