"""Arrays computed once per machine, kept in the user's cache folder.

The folder is ~/.cache/lutbake unless ``use_folder`` chose another (created
private on first use). The library reads no environment variable for it: the
command line resolves $LUTBAKE_CACHE_DIR, else $XDG_CACHE_HOME/lutbake, and
hands the result to ``use_folder`` once at start-up; a Python caller that wants
another folder calls ``use_folder`` itself (numpy is imported where the arrays
are handled, so that this costs the command line's start-up nothing).

Entries are named by a hash of everything they depend on and written
atomically. Nothing in the folder is trusted: an entry is used
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
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np

__all__ = ["cached_arrays", "use_folder", "default_folder", "writable_folder"]

_HASH = "sha256"  # the member holding the SHA-256 of the other arrays
_chosen: Path | None = None  # use_folder's choice; None: default_folder()


def default_folder() -> Path:
    """~/.cache/lutbake: the folder used until ``use_folder`` names another."""
    return Path.home() / ".cache" / "lutbake"


def use_folder(folder: str | os.PathLike[str] | None) -> Path | None:
    """Keep the cache in ``folder`` from now on (None: ``default_folder()`` again); returns the previous choice
    (None for the default), so a caller can restore it. A folder that cannot be created or written costs
    each process a rebuild of what it needs, nothing else.

    >>> previous = use_folder("/tmp/lutbake-cache-example")
    >>> _folder_path()
    PosixPath('/tmp/lutbake-cache-example')
    >>> use_folder(previous)
    PosixPath('/tmp/lutbake-cache-example')
    """
    global _chosen
    previous, _chosen = _chosen, None if folder is None else Path(folder)
    return previous


def _usable_folder(folder: Path) -> bool:
    """``folder`` exists (created if need be) and this process may create files in it."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    except OSError:
        return False
    return folder.is_dir() and os.access(folder, os.W_OK | os.X_OK)


def _folder_path() -> Path:
    return _chosen or default_folder()


def writable_folder() -> Path | None:
    """The cache folder (``use_folder``'s choice, else ``default_folder()``), created if need be, or None
    where this process cannot write it."""
    folder = _folder_path()
    return folder if _usable_folder(folder) else None


def _digest(arrays: Mapping[str, np.ndarray]) -> np.ndarray:
    """SHA-256 over each array's name, dtype, shape and bytes, in name order, as 32 uint8."""
    import numpy as np

    digest = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        digest.update(a.tobytes())
    return np.frombuffer(digest.digest(), dtype=np.uint8)


def _declared(archive: zipfile.ZipFile, name: str) -> tuple[tuple[int, ...], np.dtype]:
    """(shape, dtype) an .npy member of ``archive`` declares, read from its header alone."""
    import numpy as np

    readers = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
    with archive.open(f"{name}.npy") as member:
        version = np.lib.format.read_magic(member)
        if version not in readers:
            raise ValueError(f"npy format version {version}")
        shape, _, dtype = readers[version](member)
    return shape, dtype


def _load(path: Path, shapes: Mapping[str, Sequence[int]]) -> dict[str, np.ndarray] | None:
    """The arrays of the entry at ``path`` when it passes every check of the module docstring, else None."""
    import numpy as np

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


def _save(path: Path, arrays: Mapping[str, np.ndarray]) -> None:
    import numpy as np

    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    try:
        with open(tmp, "wb") as f:
            # numpy's stub types **kwds as if they could name savez's allow_pickle: bool
            np.savez(f, **arrays, **{_HASH: _digest(arrays)})  # type: ignore[arg-type]
        os.replace(tmp, path)
    except OSError:  # a read-only or full cache folder costs a rebuild next time, nothing else
        tmp.unlink(missing_ok=True)


def cached_arrays(
    kind: str,
    key: bytes,
    shapes: Mapping[str, Sequence[int]],
    build: Callable[[], Mapping[str, np.ndarray]],
) -> Mapping[str, np.ndarray]:
    """The arrays ``build()`` returns (name → array of ``shapes[name]``), from the cache entry for
    (``kind``, ``key``) when it is valid, else built now and stored."""
    folder = writable_folder()
    path = folder / f"{kind}-{hashlib.sha256(key).hexdigest()[:24]}.npz" if folder else None
    arrays: Mapping[str, np.ndarray] | None = _load(path, shapes) if path else None
    if arrays is None:
        arrays = build()
        if path:
            _save(path, arrays)
    return arrays
