"""Old path of load_scene: now ``lutbake.scene.toml``."""

import warnings

from lutbake.scene.toml import load_scene

__all__ = ["load_scene"]

warnings.warn(
    "lutbake.scene_toml is lutbake.scene.toml (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
