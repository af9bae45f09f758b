"""Old path of load_gltf_scene: now ``lutbake.scene.gltf.materials``."""

import warnings

from lutbake.scene.gltf.materials import load_gltf_scene

__all__ = ["load_gltf_scene"]

warnings.warn(
    "lutbake.gltf_scene is lutbake.scene.gltf.materials (the modules moved into subpackages by stage)",
    DeprecationWarning,
    stacklevel=2,
)
