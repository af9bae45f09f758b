"""Old path of Axis, BakeSpec: now ``lutbake.grid.spec``."""

import warnings

from lutbake.grid.spec import Axis, BakeSpec

__all__ = ["Axis", "BakeSpec"]

warnings.warn(
    "lutbake.plan is lutbake.grid.spec (the modules moved into subpackages by stage)", DeprecationWarning, stacklevel=2
)
