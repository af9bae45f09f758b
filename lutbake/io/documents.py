"""Reading documents lutbake did not write, or that may have been edited since: JSON and TOML texts whose
size, nesting and integers are bounded before they are parsed, from regular files only.

Python's parsers recurse once per nesting level (``json`` in C, ``tomllib`` in Python), so a file of a
few kB made of ``[[[[…`` ends in a RecursionError, and a huge file is read whole before any check. Every
document lutbake reads (EXR metadata, journals, scene files, manifests, cache records) has a small,
known nesting, so a depth past ``MAX_NESTING`` is refused up front, with one line, as ``ValueError``.
The depth is counted in fixed-size chunks and strings are skipped by a pattern that keeps no state per
character, so the check costs a constant amount of memory beside the text itself (docs/lut-format.md,
"Readers and their bounds"). A JSON integer outside ±2^53 (no double holds it exactly, so JavaScript
readers would change it; numpy cannot take one past 2^64) is refused where it is parsed.
"""

from __future__ import annotations

import json
import os
import re
import stat
import tomllib
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = ["MAX_JSON_INTEGER", "MAX_NESTING", "load_json", "load_toml", "open_regular", "read_bytes", "read_text"]

# The deepest document lutbake writes (an atlas header: slices → axes → axis) nests 5 levels; 32 leaves
# room for hand-written scene files and is far below the parsers' recursion limits (~1000).
MAX_NESTING = 32
MAX_JSON_INTEGER = 1 << 53  # every integer up to it is exact in a double (JSON's interoperable range, RFC 8259 §6)
_DEPTH_CHUNK_CHARS = 1 << 20  # the nesting count's working memory: ~13 bytes per character of one chunk

# Strings without backtracking state (possessive runs: memory does not grow with a string's length).
_JSON_STRING = re.compile(r'"[^"\\]*+(?:\\.[^"\\]*+)*+"', re.S)
# TOML strings (multi-line forms first; up to two quotes may end one's content) and comments: brackets
# inside them do not nest anything.
_TOML_SKIP = re.compile(
    r'"""(?>[^"\\]+|\\.|"(?!""))*+"{3,5}|\'\'\'.*?\'{3,5}|"(?>[^"\\\n]+|\\.)*+"|\'[^\'\n]*+\'|#[^\n]*+', re.S
)


def open_regular(path: str | os.PathLike[str], what: str) -> IO[bytes]:
    """``path`` opened for reading, refused (ValueError naming ``what``) unless it is a regular file: a FIFO,
    device or socket could block the read forever or never end. Opened without blocking and checked on
    the open descriptor, so nothing swapped in between is read."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except FileNotFoundError:
        raise ValueError(f"{what} {str(path)!r} does not exist") from None
    except OSError as exc:
        raise ValueError(f"{what} {str(path)!r} cannot be read: {exc.strerror}") from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        raise ValueError(f"{what} {str(path)!r} is not a regular file (a folder, FIFO or device)")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_bytes(path: str | os.PathLike[str], what: str, max_bytes: int) -> bytes:
    """The bytes of the regular file ``path``, refused (ValueError naming ``what``) past ``max_bytes`` before
    it is read (and again if it grew while being read)."""
    with open_regular(path, what) as fh:
        size = os.fstat(fh.fileno()).st_size
        data = fh.read(max_bytes + 1) if size <= max_bytes else b""
    if size > max_bytes or len(data) > max_bytes:
        raise ValueError(f"{what} {str(path)!r} is over {max_bytes:,} bytes: not a file lutbake reads")
    return data


def read_text(path: str | os.PathLike[str], what: str, max_bytes: int) -> str:
    """The UTF-8 text of the regular file ``path``, bounded as ``read_bytes``."""
    try:
        return read_bytes(path, what, max_bytes).decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{what} {str(Path(path))!r} is not UTF-8 text (byte {exc.start})") from None


def _depth(text: str) -> int:
    """The deepest bracket nesting of ``text`` (strings and comments already blanked), counted chunk by chunk."""
    deepest = depth = 0
    for start in range(0, len(text), _DEPTH_CHUNK_CHARS):
        codes = np.frombuffer(text[start : start + _DEPTH_CHUNK_CHARS].encode("utf-8", "replace"), dtype=np.uint8)
        steps = np.zeros(codes.shape, dtype=np.int64)
        steps[(codes == ord("[")) | (codes == ord("{"))] = 1
        steps[(codes == ord("]")) | (codes == ord("}"))] = -1
        running = depth + np.cumsum(steps)
        deepest = max(deepest, int(running.max(initial=depth)))
        depth = int(running[-1]) if running.size else depth
    return deepest


def _check_depth(blanked: str, what: str) -> None:
    depth = _depth(blanked)
    if depth > MAX_NESTING:
        raise ValueError(f"{what} nests {depth} levels deep: at most {MAX_NESTING} are allowed")


class _OutOfRange(ValueError):
    """A JSON integer past ±MAX_JSON_INTEGER."""


def _json_integer(digits: str) -> int:
    """A JSON integer, refused past ±2^53 (before Python converts a long run of digits)."""
    value = int(digits) if len(digits) <= 17 else MAX_JSON_INTEGER + 1
    if abs(value) > MAX_JSON_INTEGER:
        shown = digits if len(digits) <= 24 else f"{digits[:20]}… ({len(digits)} digits)"
        raise _OutOfRange(f"integer {shown} is outside ±2^53, the integers every JSON reader keeps exact")
    return value


def load_json(text: str, what: str) -> Any:  # any JSON value: its reader checks its shape
    """``json.loads(text)`` with nesting and integers bounded; ValueError (one line naming ``what``) if it is
    not JSON or breaks a bound."""
    _check_depth(_JSON_STRING.sub('""', text), what)
    try:
        return json.loads(text, parse_int=_json_integer)
    except _OutOfRange as exc:
        raise ValueError(f"{what}: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{what} is not JSON: {exc}") from None


def load_toml(text: str, what: str) -> dict[str, Any]:
    """``tomllib.loads(text)`` with nesting bounded; ValueError (one line naming ``what``) if it is not TOML.
    Dotted keys and table headers nest without brackets, but tomllib reads them without recursion."""
    _check_depth(_TOML_SKIP.sub('""', text), what)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{what}: invalid TOML: {exc}") from None
