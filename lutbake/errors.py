"""Errors the library raises about its inputs, worded in the library's own terms.

A ``ParameterError`` names parameters by their Python names (``opd_nm``,
``out_path``); the command line renders the same message with the flags that
set them (``--opd``, ``--out``), so the library never speaks of flags and the
CLI never re-words a message.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = ["ParameterError", "OpenCLUnavailable"]

_FIELD = re.compile(r"\{(\w+)\}")


class ParameterError(ValueError):
    """A value lutbake does not allow. ``template`` marks parameter names as ``{name}``; ``values``
    fills other fields (inserted after the names, so a value that looks like ``{name}`` stays as is).

    >>> err = ParameterError("{opd_nm} range {range} is empty or reversed", range="100:50")
    >>> str(err), err.render({"opd_nm": "--opd"})
    ('opd_nm range 100:50 is empty or reversed', '--opd range 100:50 is empty or reversed')
    """

    def __init__(self, template: str, **values: object) -> None:
        self.template: str = template
        self.values: dict[str, object] = values
        super().__init__(self.render({}))

    def render(self, names: Mapping[str, str]) -> str:
        """The message with each ``{parameter}`` shown as ``names`` gives it (default: its own name)."""
        return _FIELD.sub(
            lambda m: str(self.values[m[1]]) if m[1] in self.values else names.get(m[1], m[1]), self.template
        )


class OpenCLUnavailable(RuntimeError):
    """No usable OpenCL platform or device (lutbake/integrate/opencl.py raises it; the CLI reports it in one line)."""
