"""Output file sets: members written as temporaries, then committed as one unit.

A LUT (NAME.exr, .json, .glsl, .hlsl), the default set (six LUTs), a scene bake (atlas, manifest,
includes, LUTs) or an exact table is only correct as a whole. Writers of one folder hold an
exclusive lock on the folder (flock, released by the kernel when a process dies), so concurrent
bakes into it run one after the other. Each member is written to a hidden temporary
``.NAME.tmp-PID`` in the folder; when all are complete a journal ``.SET.commit`` listing
(temporary, final, SHA-256) is written atomically, the temporaries are renamed into place, and the
journal is removed. SIGINT and SIGTERM are held back from the journal to its removal, so a stopped
command either leaves the old set or commits the new one. A writer killed before the journal
leaves the old set (and temporaries); one killed after it leaves a journal that the next writer of
the folder rolls forward to the new set before it does anything else, and lutbake's readers refuse
a member of a set that is mid-commit. Temporaries whose process is dead are removed by the next
writer.

Nothing in a journal is trusted: it must be a regular file of at most ``MAX_JOURNAL_BYTES`` holding
exactly the document ``commit`` writes, every name a plain file name in the folder, every temporary
named after its final name, every digest 64 hex digits, and each temporary must still hash to its
digest before it is renamed. A journal that fails is refused in one line and left as it is, with
every file it names.

Test hook: ``commit_step_hook``, when a test sets it in the writer's process, is called before the
journal is written and before each rename (tests set it to stop the process there, so they can kill it
inside every window); None, the default, does nothing.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import stat
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path

from lutbake.errors import ParameterError
from lutbake.io.documents import load_json
from lutbake.io.signals import stop_signals_held

__all__ = [
    "open_set",
    "FileSet",
    "sha256_file",
    "journal_path",
    "recover",
    "remove_stale_temporaries",
    "pending_commit",
    "refuse_overwriting_inputs",
    "MAX_JOURNAL_BYTES",
]

_TEMP = re.compile(r"^\..+\.tmp-(\d+)$")
_DIGEST = re.compile(r"^[0-9a-f]{64}$")
# A journal line is ~180 bytes per member; a scene with a thousand 4D LUTs stays under 1 MiB.
MAX_JOURNAL_BYTES = 4 << 20
commit_step_hook: Callable[[], None] | None = None  # tests only (module docstring)


def sha256_file(path: str | os.PathLike[str]) -> str:
    """The SHA-256 of the file at ``path``, as 64 hex digits (read in 1 MiB blocks)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def refuse_overwriting_inputs(
    inputs: Mapping[str, str | os.PathLike[str]], outputs: Iterable[str | os.PathLike[str]]
) -> None:
    """ParameterError, before anything is written, when an output is one of the inputs (``inputs``: what to call
    it → path), the same file by any path or hard link; an output that does not exist yet is compared by where
    it would be.

    >>> refuse_overwriting_inputs({"LUT": "x.exr"}, ["report.html"])
    >>> refuse_overwriting_inputs({"LUT": "x.exr"}, ["./x.exr"])
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: LUT 'x.exr' would be overwritten by the output './x.exr': write the output elsewhere
    """
    for what, path in inputs.items():
        for out in outputs:
            if _same_file(Path(path), Path(out)):
                raise ParameterError(
                    "{what} {path} would be overwritten by the output {out}: write the output elsewhere",
                    what=what,
                    path=repr(str(path)),
                    out=repr(str(out)),
                )


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist (yet): compare where they would be
        return a.resolve() == b.resolve()


def journal_path(folder: str | os.PathLike[str], set_name: str) -> Path:
    """Where the set ``set_name``'s commit journal lies in ``folder``: ``.SET.commit``."""
    return Path(folder) / f".{set_name}.commit"


def temporary_for(final: Path) -> Path:
    """The temporary this process writes ``final`` to: ``.NAME.tmp-PID`` beside it."""
    return final.with_name(f".{final.name}.tmp-{os.getpid()}")


class FileSet:
    """Members of one set, written to temporaries until ``commit``."""

    def __init__(self, folder: str | os.PathLike[str], name: str) -> None:
        _require_plain(name, "set name")
        self.folder, self.name = Path(folder), name
        self.members: dict[Path, Path] = {}  # final path -> temporary path

    def temp(self, final: str | os.PathLike[str]) -> Path:
        """The temporary to write the member ``final`` (a file in the set's folder) to."""
        final = Path(final)
        if final.parent.resolve() != self.folder.resolve():
            raise ValueError(f"output {str(final)!r} is not in the set's folder {str(self.folder)!r}")
        if final.is_dir():
            raise ValueError(f"output {str(final)!r} is a folder, expected a file")
        self.members[final] = temporary_for(final)
        return self.members[final]

    def commit(self) -> None:
        """Journal the members, rename each into place, remove the journal (module docstring)."""
        if not self.members:
            return
        entries = [[tmp.name, final.name, sha256_file(tmp)] for final, tmp in self.members.items()]
        journal = journal_path(self.folder, self.name)
        with stop_signals_held():
            _commit_step()
            _write_durably(temporary_for(journal), json.dumps({"set": self.name, "members": entries}))
            os.replace(temporary_for(journal), journal)
            _roll_forward(self.folder, entries, journal)
            journal.unlink()
        self.members = {}

    def discard(self) -> None:
        """Remove the members' temporaries: the folder keeps its previous set."""
        for tmp in self.members.values():
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


@contextlib.contextmanager
def open_set(folder: str | os.PathLike[str], name: str) -> Iterator[FileSet]:
    """Lock ``folder``, finish interrupted commits, drop dead temporaries; yield a FileSet
    that is committed when the block succeeds and discarded when it raises (the CLI turns
    SIGTERM into an exception: lutbake/io/signals.py)."""
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


def recover(folder: str | os.PathLike[str]) -> None:
    """Roll every journaled (complete) commit in ``folder`` forward; call with the lock held. A journal
    that is not one lutbake wrote, or whose files changed since, raises ValueError and is left alone."""
    for journal in sorted(Path(folder).glob(".*.commit")):
        entries = read_journal(journal)
        with stop_signals_held():
            _roll_forward(Path(folder), entries, journal)
            journal.unlink()


def read_journal(journal: Path) -> list[list[str]]:
    """The validated (temporary, final, digest) entries of ``journal`` (see the module docstring)."""
    try:
        _require(stat.S_ISREG(os.lstat(journal).st_mode), "not a regular file")
        with open(journal, "rb") as fh:
            data = fh.read(MAX_JOURNAL_BYTES + 1)
        _require(len(data) <= MAX_JOURNAL_BYTES, f"over {MAX_JOURNAL_BYTES:,} bytes")
        doc = load_json(data.decode("utf-8"), "it")
        _require(isinstance(doc, dict) and set(doc) == {"set", "members"}, "keys are not set, members")
        _require_plain(doc["set"], "set")
        _require(journal.name == f".{doc['set']}.commit", "its name is not that of its set")
        members = doc["members"]
        _require(isinstance(members, list) and len(members) > 0, "members is not a non-empty list")
        for entry in members:
            _require(
                isinstance(entry, list) and len(entry) == 3 and all(isinstance(v, str) for v in entry),
                "a member is not [temporary, final, sha256]",
            )
            tmp, final, digest = entry
            _require_plain(final, "final name")
            _require(
                _TEMP.match(tmp) is not None and tmp.startswith(f".{final}.tmp-"),
                f"temporary {tmp!r} is not named after {final!r}",
            )
            _require(_DIGEST.match(digest) is not None, f"digest of {final!r} is not 64 hex digits")
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ValueError(
            f"commit journal {str(journal)!r} is not one lutbake wrote ({_reason(exc)}); it and the "
            "files it names were left as they are: remove it and bake again"
        ) from None
    return members


def pending_commit(path: str | os.PathLike[str]) -> Path | None:
    """The journal in ``path``'s folder that names ``path`` as a member (or cannot be read), else None."""
    path = Path(path)
    for journal in sorted(path.parent.glob(".*.commit")):
        try:
            if any(final == path.name for _, final, _ in read_journal(journal)):
                return journal
        except ValueError:
            return journal
    return None


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> None:
    """Remove the temporaries in ``folder`` whose writing process is dead (call with the lock held)."""
    for path in Path(folder).iterdir():
        match = _TEMP.match(path.name)
        if match and path.is_file() and not _alive(int(match.group(1))):
            with contextlib.suppress(FileNotFoundError):
                path.unlink()


def _roll_forward(folder: Path, entries: Iterable[Sequence[str]], journal: Path) -> None:
    for tmp_name, final_name, digest in entries:
        tmp, final = folder / tmp_name, folder / final_name
        if _regular(tmp):
            if sha256_file(tmp) != digest:
                raise ValueError(
                    f"{str(tmp)!r} changed after an interrupted commit: remove {str(journal)!r} and bake again"
                )
            _commit_step()
            os.replace(tmp, final)
        elif not (_regular(final) and sha256_file(final) == digest):
            raise ValueError(
                f"{str(final)!r} changed after an interrupted commit: remove {str(journal)!r} and bake again"
            )
    _fsync_folder(folder)


def _regular(path: Path) -> bool:
    """A regular file, not a link, folder or FIFO (reading a FIFO would wait for a writer forever)."""
    try:
        return stat.S_ISREG(os.lstat(path).st_mode)
    except FileNotFoundError:
        return False


def _require(ok: bool, why: str) -> None:
    if not ok:
        raise ValueError(why)


def _require_plain(name: object, what: str) -> None:
    """``name`` is a plain file name: a string naming an entry of the folder itself."""
    _require(
        isinstance(name, str) and name not in ("", ".", "..") and "/" not in name and "\0" not in name,
        f"{what} {name!r} is not a plain file name",
    )


def _reason(exc: Exception) -> str:
    return exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)


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


def _commit_step() -> None:
    if commit_step_hook is not None:
        commit_step_hook()
