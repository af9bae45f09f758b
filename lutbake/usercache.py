"""Arrays computed once per machine, kept in the user's cache folder.

$LUTBAKE_CACHE_DIR, else $XDG_CACHE_HOME/lutbake, else ~/.cache/lutbake
(created private). Entries are named by a hash of everything they depend on,
written atomically, and checked when read: an entry that is unreadable, of the
wrong shape or not finite is rebuilt. Without a writable folder each process
rebuilds what it needs; nothing else changes.
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from pathlib import Path

import numpy as np

__all__ = ["cached_arrays"]


def _folder() -> Path | None:
    home = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    folder = Path(os.environ.get("LUTBAKE_CACHE_DIR") or Path(home) / "lutbake")
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError:
        return None
    return folder


def _load(path: Path, shapes: dict) -> dict | None:
    try:
        with np.load(path, allow_pickle=False) as stored:
            arrays = {name: stored[name] for name in shapes}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None
    ok = all(a.shape == shapes[n] and np.isfinite(a).all() for n, a in arrays.items())
    return arrays if ok else None


def _save(path: Path, arrays: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)
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
