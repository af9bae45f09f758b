"""A scene from its one source: lutbake's scene manifest (TOML, docs/scene.md) or a glTF asset's
KHR_materials_iridescence materials (docs/gltf.md), as `bake --scene`/`--gltf` and `plan` read it.

A glTF asset's metals become η3 + iκ3 by ``metal_mapping`` ('fitted' unless another is named); what the
mapping could not honour is kept as warnings beside the scene (``source_warnings``), which the command
line prints one line each.
"""

from __future__ import annotations

from collections.abc import Sequence
from os import PathLike

from lutbake.errors import ParameterError
from lutbake.scene.model import Scene

__all__ = ["load_scene_source", "source_warnings"]


def load_scene_source(
    scene_path: str | PathLike[str] | None = None,
    gltf_path: str | PathLike[str] | None = None,
    metal_mapping: str | None = None,
    routes: Sequence[str] = (),
) -> Scene:
    """The scene model from exactly one of ``scene_path`` (TOML) and ``gltf_path`` (.gltf/.glb, its metals
    mapped by ``metal_mapping``: 'fitted' (default), 'threejs' or a JSON file naming a lutbake material per
    glTF material; ``routes``: 'MATERIAL=runtime|bake' per glTF material). ParameterError for none or
    both, or a ``metal_mapping`` without a glTF asset.

    >>> load_scene_source()
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: give exactly one of scene_path FILE.toml or gltf_path ASSET.gltf|.glb
    """
    if bool(scene_path) == bool(gltf_path):
        raise ParameterError("give exactly one of {scene_path} FILE.toml or {gltf_path} ASSET.gltf|.glb")
    if scene_path:
        if metal_mapping is not None:
            raise ParameterError("{metal_mapping} applies to {gltf_path} only")
        from lutbake.scene.toml import load_scene

        return load_scene(scene_path)
    from lutbake.scene.gltf.materials import load_gltf_scene

    assert gltf_path  # one of the two, checked above
    return load_gltf_scene(gltf_path, metal_mapping or "fitted", routes=routes)


def source_warnings(scene: Scene) -> list[str]:
    """What the source could not honour, one line each naming the file: a glTF asset's warnings, then each
    material's (none for a TOML scene)."""
    if scene.source is None:
        return []
    lines = scene.source["asset_warnings"] + [w for r in scene.source["materials"] for w in r["warnings"]]
    return [f"{scene.file_name}: {line}" for line in lines]
