"""Reading documents lutbake did not write, or that may have been edited since: JSON and TOML texts whose
size and nesting are bounded before they are parsed.

Python's parsers recurse once per nesting level (``json`` in C, ``tomllib`` in Python), so a file of a
few kB made of ``[[[[…`` ends in a RecursionError, and a huge file is read whole before any check. Every
document lutbake reads (EXR metadata, journals, scene files, manifests, cache records) has a small,
known nesting, so a depth past ``MAX_NESTING`` is refused up front, with one line, as ``ValueError``.
"""

from __future__ import annotations

import json
import os
import re
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["MAX_NESTING", "load_json", "load_toml", "read_text"]

# The deepest document lutbake writes (an atlas header: slices → axes → axis) nests 5 levels; 32 leaves
# room for hand-written scene files and is far below the parsers' recursion limits (~1000).
MAX_NESTING = 32

_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
# TOML strings (multi-line forms first) and comments: brackets inside them do not nest anything.
_TOML_SKIP = re.compile(r'"""(?:[^\\]|\\.)*?"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*', re.S)


def read_text(path: str | os.PathLike[str], what: str, max_bytes: int) -> str:
    """The UTF-8 text of ``path``, refused (ValueError naming ``what``) past ``max_bytes`` before it is read."""
    path = Path(path)
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise ValueError(f"{what} {str(path)!r} is over {max_bytes:,} bytes: not a file lutbake wrote")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{what} {str(path)!r} is not UTF-8 text (byte {exc.start})") from None


def _depth(text: str) -> int:
    """The deepest bracket nesting of ``text`` (strings and comments already blanked)."""
    codes = np.frombuffer(text.encode("utf-8", "replace"), dtype=np.uint8)
    steps = np.zeros(codes.shape, dtype=np.int64)
    steps[(codes == ord("[")) | (codes == ord("{"))] = 1
    steps[(codes == ord("]")) | (codes == ord("}"))] = -1
    return int(np.cumsum(steps).max(initial=0))


def _check_depth(blanked: str, what: str) -> None:
    depth = _depth(blanked)
    if depth > MAX_NESTING:
        raise ValueError(f"{what} nests {depth} levels deep: at most {MAX_NESTING} are allowed")


def load_json(text: str, what: str) -> Any:  # any JSON value: its reader checks its shape
    """``json.loads(text)`` with nesting bounded; ValueError (one line naming ``what``) if it is not JSON."""
    _check_depth(_JSON_STRING.sub('""', text), what)
    try:
        return json.loads(text)
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
