"""Output file sets: members written as temporaries, then committed as one unit.

A LUT (NAME.exr, .json, .glsl, .hlsl) or a scene bake (atlas, manifest,
includes, LUTs) is only correct as a whole. Writers of one folder hold an
exclusive lock on the folder (flock, released by the kernel when a process
dies), so concurrent bakes into it run one after the other. Each member is
written to a hidden temporary ``.NAME.tmp-PID``; when all are complete a
journal ``.SET.commit`` listing (temporary, final, SHA-256) is written
atomically, the temporaries are renamed into place, and the journal is
removed. A writer killed before the journal leaves the old set (and
temporaries); one killed after it leaves a journal that the next writer of
the folder rolls forward to the new set before it does anything else, and
lutbake's readers refuse a LUT whose set is mid-commit. Temporaries whose
process is dead are removed by the next writer.

Test hook: with LUTBAKE_TEST_STOP_BEFORE_RENAME=1 in the environment a
writer stops itself (SIGSTOP) before writing the journal and before each
rename, so tests can kill it inside every window.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import signal
from pathlib import Path

__all__ = ["open_set", "FileSet", "sha256_file", "journal_path", "recover", "remove_stale_temporaries"]

_TEMP = re.compile(r"^\..+\.tmp-(\d+)$")
_STOP_HOOK = "LUTBAKE_TEST_STOP_BEFORE_RENAME"


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def journal_path(folder: Path, set_name: str) -> Path:
    return Path(folder) / f".{set_name}.commit"


def temporary_for(final: Path) -> Path:
    return final.with_name(f".{final.name}.tmp-{os.getpid()}")


class FileSet:
    """Members of one set, written to temporaries until ``commit``."""

    def __init__(self, folder: Path, name: str):
        self.folder, self.name = Path(folder), name
        self.members = {}  # final path -> temporary path

    def temp(self, final) -> Path:
        final = Path(final)
        if final.is_dir():
            raise ValueError(f"output {str(final)!r} is a folder, expected a file")
        self.members[final] = temporary_for(final)
        return self.members[final]

    def commit(self) -> None:
        if not self.members:
            return
        entries = [[tmp.name, final.name, sha256_file(tmp)] for final, tmp in self.members.items()]
        journal = journal_path(self.folder, self.name)
        _test_stop()
        _write_durably(temporary_for(journal), json.dumps({"set": self.name, "members": entries}))
        os.replace(temporary_for(journal), journal)
        _roll_forward(self.folder, entries, journal)
        journal.unlink()
        self.members = {}

    def discard(self) -> None:
        for tmp in self.members.values():
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


@contextlib.contextmanager
def open_set(folder, name: str):
    """Lock ``folder``, finish interrupted commits, drop dead temporaries; yield a FileSet
    that is committed when the block succeeds and discarded when it raises (the CLI turns
    SIGTERM into an exception: signals.py)."""
    folder = Path(folder)
    fd = os.open(folder, os.O_RDONLY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        recover(folder)
        remove_stale_temporaries(folder)
        files = FileSet(folder, name)
        try:
            yield files
        except BaseException:
            files.discard()
            raise
        files.commit()
    finally:
        os.close(fd)


def recover(folder: Path) -> None:
    """Roll every journaled (complete) commit in ``folder`` forward; call with the lock held."""
    for journal in sorted(Path(folder).glob(".*.commit")):
        try:
            entries = json.loads(journal.read_text())["members"]
        except (ValueError, KeyError, TypeError):
            raise ValueError(f"commit journal {str(journal)!r} is damaged: remove it and bake again") from None
        _roll_forward(Path(folder), entries, journal)
        journal.unlink()


def remove_stale_temporaries(folder: Path) -> None:
    for path in Path(folder).iterdir():
        match = _TEMP.match(path.name)
        if match and path.is_file() and not _alive(int(match.group(1))):
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


def _roll_forward(folder: Path, entries, journal: Path) -> None:
    for tmp_name, final_name, digest in entries:
        tmp, final = folder / tmp_name, folder / final_name
        if tmp.is_file():
            _test_stop()
            os.replace(tmp, final)
        elif not (final.is_file() and sha256_file(final) == digest):
            raise ValueError(f"{str(final)!r} changed after an interrupted commit: remove {str(journal)!r} "
                             "and bake again")
    _fsync_folder(folder)


def _write_durably(path: Path, text: str) -> None:
    with open(path, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())


def _fsync_folder(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return False  # an earlier set of this process already committed or discarded its own
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _test_stop() -> None:
    if os.environ.get(_STOP_HOOK) == "1":
        os.kill(os.getpid(), signal.SIGSTOP)

