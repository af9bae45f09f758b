"""The environment the command line honours, read once at its edge and passed down as values: the library
reads no environment variable.

- ``LUTBAKE_DEVICE``: the OpenCL device when --device is not given (the value a command passes as
  ``device=``); without it, pyopencl's own ``PYOPENCL_CTX`` (platform[:device], passed as a
  ``PyopenclCtx`` selector, read by pyopencl's rules; docs/devices.md).
- ``OPENCL_VENDOR_PATH``: the system's ICD vendor folder `devices --icd-folder` links (default
  /etc/OpenCL/vendors).
- ``LUTBAKE_BLENDER``: the Blender `lutbake blender` runs when --blender is not given.
- ``LUTBAKE_CACHE_DIR``, else ``XDG_CACHE_HOME``/lutbake: the user cache (lutbake/io/usercache.py), else
  its default, ~/.cache/lutbake.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lutbake.integrate.devices import PyopenclCtx

__all__ = ["Environment"]


@dataclass(frozen=True)
class Environment:
    """What the environment asks of lutbake; None where it asks nothing."""

    device: str | None = None
    blender: str | None = None
    cache_folder: Path | None = None
    system_vendors: Path | None = None

    @classmethod
    def read(cls, environ: Mapping[str, str]) -> Environment:
        """From ``environ`` (a mapping such as os.environ); empty values count as unset.

        >>> Environment.read({"LUTBAKE_DEVICE": "pocl", "XDG_CACHE_HOME": "/c", "LUTBAKE_BLENDER": ""})
        Environment(device='pocl', blender=None, cache_folder=PosixPath('/c/lutbake'), system_vendors=None)
        >>> type(Environment.read({"PYOPENCL_CTX": "0:1"}).device).__name__
        'PyopenclCtx'
        """

        cache = environ.get("LUTBAKE_CACHE_DIR") or (
            Path(environ["XDG_CACHE_HOME"]) / "lutbake" if environ.get("XDG_CACHE_HOME") else None
        )
        return cls(
            device=environ.get("LUTBAKE_DEVICE") or _pyopencl_ctx(environ.get("PYOPENCL_CTX")),
            blender=environ.get("LUTBAKE_BLENDER") or None,
            cache_folder=None if cache is None else Path(cache),
            system_vendors=Path(environ["OPENCL_VENDOR_PATH"]) if environ.get("OPENCL_VENDOR_PATH") else None,
        )

    def apply(self) -> None:
        """Point the library's process-wide settings at what the environment asks (the user cache's folder)."""
        from lutbake.io import usercache

        usercache.use_folder(self.cache_folder)


def _pyopencl_ctx(value: str | None) -> PyopenclCtx | None:
    """PYOPENCL_CTX as a device selector read by pyopencl's rules, or None where it is unset."""
    if not value:
        return None
    from lutbake.integrate.devices import PyopenclCtx

    return PyopenclCtx(value)
