"""Old path of bake_scene: now ``lutbake.scene.bake``."""

import warnings

from lutbake.scene.bake import bake_scene

__all__ = ["bake_scene"]

warnings.warn(
    "lutbake.scene_bake is lutbake.scene.bake (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
