"""The runtime path: any film, any base, six bilinear reads of one table per pixel (docs/engines.md).

Stages, a module each: ``transform`` (the film- and base-independent function U(X, w), float64:
``transform_table``, ``transform_values``, ``slice_values``) → ``files`` (the RGBA half EXR, sidecar and
GLSL/HLSL includes `lutbake runtime-table` writes: ``write_runtime_table``, ``read_runtime_table``,
``stored_table``, ``RuntimeTable``) → ``model`` (the include's float32 arithmetic in numpy, what a GPU
returns: ``runtime_colour``, ``runtime_rgb``); beside them ``costs`` (each runtime path's error against its
cost, the table `lutbake report` prints: ``path_costs``, ``cost_rows``, ``cost_table_text``, ``cost_table_html``).
"""

from lutbake.modes.runtime.files import RuntimeTable, read_runtime_table, stored_table, write_runtime_table
from lutbake.modes.runtime.model import runtime_colour, runtime_rgb

__all__ = ["RuntimeTable", "read_runtime_table", "stored_table", "write_runtime_table", "runtime_colour", "runtime_rgb"]
