"""Old path of FilmPoints: now ``lutbake.physics.points``."""

import warnings

from lutbake.physics.points import FilmPoints

__all__ = ["FilmPoints"]

warnings.warn(
    "lutbake.points is lutbake.physics.points (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
