"""The runtime path: any film, any base, six bilinear reads of one table per pixel (docs/engines.md).

Stages: transform (the film- and base-independent function U(X, w), float64) → files (the RGBA half
EXR, sidecar and GLSL/HLSL includes `lutbake runtime-table` writes) → model (the include's float32
arithmetic in numpy: what a GPU returns).
"""

from lutbake.modes.runtime.files import RuntimeTable, read_runtime_table, stored_table, write_runtime_table
from lutbake.modes.runtime.model import runtime_colour, runtime_rgb

__all__ = ["RuntimeTable", "read_runtime_table", "stored_table", "write_runtime_table", "runtime_colour", "runtime_rgb"]
