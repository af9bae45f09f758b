"""Strict JSON for every document lutbake prints or writes: non-finite numbers become null.

Python's json writes NaN and Infinity, which strict parsers (JavaScript's
JSON.parse, jq) reject; a missing figure (e.g. ns/eval of a LUT row) is null.
"""

from __future__ import annotations

import json
import math

__all__ = ["dumps", "finite_or_none"]


def finite_or_none(value: object) -> object:
    """``value`` with every non-finite float (also inside dicts, lists, numpy scalars) as None."""
    if isinstance(value, dict):
        return {k: finite_or_none(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_none(v) for v in value]
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:  # numpy scalar
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def dumps(doc: object, indent: int = 2) -> str:
    """``doc`` as strict JSON text: every non-finite float written as null."""
    return json.dumps(finite_or_none(doc), indent=indent, allow_nan=False)
