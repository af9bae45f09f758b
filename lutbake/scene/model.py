"""The scene model: what a scene bake needs, whatever file it was read from (docs/scene.md).

A ``Scene`` is its settings (colour space, observer, ambient η1, storage precision, the p99 ΔE00
target) and its materials; a ``SceneMaterial`` is a film (η2 or a named dispersive dielectric), a
thickness range in nm and a base ((η3, κ3), a named material, or η3/κ3 ranges), with ``origin``:
where each value came from, so an error found later (the optical-path limit in the plan) names the
source's field, not a flag the user never gave. The sources build it: ``scene_toml`` (lutbake's
TOML) and ``gltf_scene`` (KHR_materials_iridescence in a glTF asset); ``scene.source`` is what a
source adds to the manifest (the glTF materials and their mapping), opaque to every later stage.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeAlias

from lutbake.io.names import shader_identifier

__all__ = ["Scene", "SceneMaterial", "check_material_names", "MATERIAL_NAME"]

# Names become shader identifiers (LUTBAKE_<SCENE>_<NAME>): ASCII only, as GLSL and HLSL allow.
MATERIAL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,63}")
# A film: its index η2, or a named (dispersive) dielectric.
Film: TypeAlias = float | str
# A base: (η3, κ3), a named material, or ((η3 lo, hi), (κ3 lo, hi)) ranges.
Base: TypeAlias = tuple[float, float] | str | tuple[tuple[float, float], tuple[float, float]]
# A ranged base's curve: (η3 nodes, κ3 nodes, the fraction of it each channel reaches).
BasePath: TypeAlias = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]


@dataclass(frozen=True)
class SceneMaterial:
    """One material: film (η2 or a name), thickness (lo, hi) in nm (lo == hi: fixed), base ((η3, κ3),
    a name, or ((η3 lo, hi), (κ3 lo, hi)) ranges), and ``origin``: field → where its value came from
    ('scene.toml:4: materials.a.thickness_nm'); not part of what the material's pixels depend on. A ranged
    base may give ``base_path``, (η3 nodes, κ3 nodes, per-channel reach) of the curve the engine reads the
    ranges along (a texture-driven glTF metal's mapping; channel c reaches the fraction reach[c] of the
    curve from its first node): its 4D LUT is then scored there, not over the whole box."""

    name: str
    film: Film
    thickness_nm: tuple[float, float]
    base: Base
    origin: Mapping[str, object] = field(default_factory=dict, compare=False, hash=False, repr=False)
    base_path: BasePath | None = None  # ranged bases only: (η3 nodes, κ3 nodes, channel reach) the engine reads

    @property
    def base_is_range(self) -> bool:
        return isinstance(self.base, tuple) and isinstance(self.base[0], tuple)

    def slice_key(self) -> dict[str, Any]:
        """Everything the material's pixels depend on (materials equal here share a slice)."""
        key = {"film": self.film, "thickness_nm": list(self.thickness_nm), "base": json.loads(json.dumps(self.base))}
        if self.base_path is not None:
            key["base_path"] = dict(
                zip(("eta3", "kappa3", "channel_reach"), ([float(v) for v in nodes] for nodes in self.base_path))
            )
        return key

    def where(self, key: str) -> str:
        """Where ``key`` ('film', 'thickness_nm', 'base') was read, for messages."""
        return str(self.origin.get(key, f"materials.{self.name}.{key}"))


@dataclass(frozen=True)
class Scene:
    """Settings and materials of a scene read from ``path``; ``source``: the source's own manifest
    section (or None); ``inputs``: the other files it read (a bake refuses to overwrite any of them)."""

    path: str
    space: str
    observer: str
    eta1: float
    precision: str
    max_de: float
    materials: tuple[SceneMaterial, ...]
    source: dict[str, Any] | None = field(default=None, compare=False)  # the source's manifest section
    inputs: tuple[str, ...] = field(default=(), compare=False)  # files the source read besides ``path``

    @property
    def file_name(self) -> str:
        """The scene file's name: what outputs record (not the path as typed, which depends on the cwd)."""
        return Path(self.path).name

    @property
    def stem(self) -> str:
        """The name of the scene's outputs (SCENE.exr, .json, .glsl, .hlsl)."""
        return Path(self.path).stem

    def settings_key(self) -> dict[str, str | float]:
        return {
            "space": self.space,
            "observer": self.observer,
            "eta1": self.eta1,
            "precision": self.precision,
            "max_de": self.max_de,
        }

    def hash_of(self, *parts: object) -> str:
        from lutbake import __version__

        text = json.dumps([self.settings_key(), *parts, __version__], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


def check_material_names(names: Iterable[str], error: Callable[[str, str], Exception]) -> None:
    """Refuse names that are no shader identifier or that collide once sanitised (a-b and A_B);
    ``error(name, message)`` returns the exception to raise."""
    seen: dict[str, str] = {}
    for name in names:
        if not MATERIAL_NAME.fullmatch(name):
            raise error(
                name,
                f"material name {name!r} is not allowed: use 1-64 ASCII letters, digits, '-' or "
                "'_', starting with a letter",
            )
        ident = shader_identifier(name)
        if ident in seen:
            raise error(name, f"material names {seen[ident]!r} and {name!r} both become {ident} in shaders: rename one")
        seen[ident] = name
