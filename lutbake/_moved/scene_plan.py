"""Old path of plan_scene: now ``lutbake.scene.plan``."""

import warnings

from lutbake.scene.plan import plan_scene

__all__ = ["plan_scene"]

warnings.warn(
    "lutbake.scene_plan is lutbake.scene.plan (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
