"""Old path of Atlas, Lut: now ``lutbake.lut.sample``."""

import warnings

from lutbake.lut.sample import Atlas, Lut

__all__ = ["Atlas", "Lut"]

warnings.warn(
    "lutbake.sample is lutbake.lut.sample (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
