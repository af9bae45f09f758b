"""Old path of reference_colour, reference_rgb: now ``lutbake.spectral.reference``."""

import warnings

from lutbake.spectral.reference import reference_colour, reference_rgb

__all__ = ["reference_colour", "reference_rgb"]

warnings.warn(
    "lutbake.reference is lutbake.spectral.reference (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
