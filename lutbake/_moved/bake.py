"""Old path of BakeResult, bake, default_specs: now ``lutbake.lut.bake``."""

import warnings

from lutbake.lut.bake import BakeResult, bake, default_specs

__all__ = ["BakeResult", "bake", "default_specs"]

warnings.warn(
    "lutbake.bake is lutbake.lut.bake (the modules moved into subpackages by stage)", DeprecationWarning, stacklevel=2
)
