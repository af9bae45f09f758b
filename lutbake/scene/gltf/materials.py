"""The glTF scene source: KHR_materials_iridescence materials of a glTF asset, mapped to the scene
model (docs/gltf.md).

Every material with KHR_materials_iridescence that a mesh primitive uses (directly or through
KHR_materials_variants) is mapped; unused ones are listed, not baked. The mapping, recorded per
material in the manifest's ``source`` section:

* ambient η1 = 1; film η2 = iridescenceIor exactly (default 1.3, never snapped); thickness the range
  [min, max] (sorted: the spec allows min > max) when iridescenceThicknessTexture is present, else
  iridescenceThicknessMaximum (default 400 nm); iridescenceFactor 0 (its default: a material that omits
  it has no film): nothing baked (the factor and iridescenceTexture only blend the film term in the
  engine); a part of a film of the ambient's index on a base of it (vacuum over vacuum) reflects
  nothing: the constant 0, nothing baked, said so;
* the dielectric part (metalness < 1 somewhere): base η3 = ior (KHR_materials_ior, default 1.5), or per
  channel the real index of the F0 KHR_materials_specular gives it (lutbake/scene/gltf/extensions.py);
* the metal part (metalness > 0 somewhere): each channel's base colour F0 → (η3, κ3) by the metal
  mapping (lutbake/physics/metals.py: ``fitted`` or ``threejs``), or one named lutbake material (a mapping file or
  the material's ``extras.lutbake.metal``); a texture-driven base colour cannot be one slice, so it
  gets a 4D LUT over the (η3, κ3) its texture can reach, and the manifest carries the F0 → (η3, κ3)
  table the engine maps each texel's colour through. A metallicRoughnessTexture makes metalness
  vary: both parts are baked and the engine mixes them as glTF does.

Draft or unknown keys (``iridescenceIOR``) and values outside the extension's ranges that lutbake can
still bake are warnings naming the material; a value nothing sensible can be baked from (wrong type,
negative thickness, an index outside lutbake's domain) is a one-line ValueError.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.errors import ParameterError
from lutbake.physics.materials import material as named_material
from lutbake.physics.metals import F0_MAX, MAPPINGS, conductor, reflectance_error
from lutbake.physics.points import check_value
from lutbake.scene.gltf.asset import GltfAsset, read_gltf
from lutbake.scene.gltf.extensions import (
    EXCLUDED,
    OTHER_LAYERS,
    SPECULAR,
    SPECULAR_TEXTURES,
    asset_notes,
    dielectric_f0,
)
from lutbake.scene.gltf.mapping import read_metal_mapping
from lutbake.scene.gltf.routes import planned_routes
from lutbake.scene.gltf.scoring import served_materials
from lutbake.scene.model import Base, BasePath, Scene, SceneMaterial, check_material_names

if TYPE_CHECKING:
    from lutbake.scene.plan import ScenePlan

__all__ = ["load_gltf_scene", "METAL_TABLE_NODES", "FILM_DEFAULTS"]

_EXT = "KHR_materials_iridescence"
_AMBIENT_INDEX = 1.0  # glTF's outside_ior: the film term is defined under air
FILM_DEFAULTS = {
    "iridescenceFactor": 0.0,
    "iridescenceIor": 1.3,
    "iridescenceThicknessMinimum": 100.0,
    "iridescenceThicknessMaximum": 400.0,
}
_KNOWN_KEYS = set(FILM_DEFAULTS) | {"iridescenceTexture", "iridescenceThicknessTexture", "extensions", "extras"}
_DRAFT_KEYS = {"iridescenceIOR": "iridescenceIor"}
METAL_TABLE_NODES = 65  # F0 → (η3, κ3) nodes the engine interpolates for a texture-driven metal


def load_gltf_scene(
    path: str | PathLike[str], metal_mapping: str = "fitted", max_de: float = 1.0, routes: Sequence[str] = ()
) -> Scene:
    """Read a glTF asset (.gltf or .glb) into a scene: its used iridescent materials, mapped.

    Parameters
    ----------
    path : str or os.PathLike
        The asset.
    metal_mapping : str
        'fitted' (default), 'threejs', or a JSON file {"default": "fitted"|"threejs", "materials":
        {"NAME or INDEX": "lutbake material name"}} naming a lutbake material per glTF material.
    max_de : float
        The target p99 ΔE00 of every slice (as a scene file's ``max_de``).
    routes : sequence of str
        'NAME or INDEX=runtime|bake' per glTF material (`--route`), over its ``extras.lutbake.route``:
        ``runtime`` serves its parts from the runtime table, unbaked (a named metal stays baked); ``bake`` keeps
        them baked where they miss their target (else such a part goes to the runtime table: routes.py).

    Returns
    -------
    Scene
        Settings rec709 / cie1931 / η1 1 / half; materials named ``m<index>-<name>-<part>``; ``source``
        the per-glTF-material record (values read, defaults, mapping, parts, warnings).

    Raises
    ------
    ValueError
        One line naming the file, the material and the field.

    Examples
    --------
    >>> import json, lutbake
    >>> film = {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": 1.33,
    ...                                       "iridescenceThicknessMaximum": 380}}  # the factor defaults to 0
    >>> asset = {"asset": {"version": "2.0"}, "materials": [
    ...     {"name": "bubble", "extensions": film, "pbrMetallicRoughness": {"metallicFactor": 0}}],
    ...     "meshes": [{"primitives": [{"attributes": {}, "material": 0}]}]}
    >>> _ = open("bubble.gltf", "w").write(json.dumps(asset))
    >>> scene = lutbake.load_gltf_scene("bubble.gltf")
    >>> [(m.name, m.film, m.thickness_nm, m.base) for m in scene.materials]
    [('m0-bubble-dielectric', 1.33, (380.0, 380.0), (1.5, 0.0))]
    >>> lutbake.bake_scene(scene, "baked").unmet
    {}
    """
    asset = read_gltf(path)
    default, named, mapping_file = _metal_mapping(metal_mapping, asset)
    records, materials, notes = _iridescent_materials(asset, named, default, _routes(routes, asset))
    check_material_names([m.name for m in materials], lambda name, message: asset.error(name, message))
    max_de = float(check_value("max_de", max_de)[0])
    source = {
        "kind": "gltf",
        "asset": asset.path.name,
        "metal_mapping": default,
        "mapping_file": None if mapping_file is None else Path(mapping_file).name,
        "asset_warnings": asset.warnings + asset_notes(notes) + _no_interference_note(records),
        "materials": records,
    }
    inputs = () if mapping_file is None else (str(mapping_file),)
    return Scene(str(asset.path), "rec709", "cie1931", 1.0, "half", max_de, tuple(materials), source, inputs)


def _iridescent_materials(
    asset: GltfAsset, named: dict[int, str], default: str, routes: dict[int, str]
) -> tuple[list[dict[str, Any]], list[SceneMaterial], dict[str, list[str]]]:
    """(the record of every glTF material with the iridescence extension, the scene materials of those
    the meshes use and that have a film, {extension lutbake does not bake: the labels of the materials
    with a film that use it}), in the asset's order; a metal base mapped by ``named`` (index → lutbake
    material), else by the material's extras, else by ``default``."""
    used = asset.used_materials()
    records: list[dict[str, Any]] = []
    materials: list[SceneMaterial] = []
    notes: dict[str, list[str]] = {}
    for index, body in enumerate(asset.materials):
        ext = asset.object(
            asset.object(body, "extensions", f"materials[{index}]"), _EXT, f"materials[{index}].extensions"
        )
        if _EXT not in body.get("extensions", {}):
            continue
        reader = _MaterialReader(asset, index, body, ext)
        record = reader.record(used.get(index, []))
        if index in used and record["film"] is not None:
            parts = _Parts(reader, record, named.get(index) or reader.extras_metal(), default)
            route = routes.get(index) or reader.extras_route()
            by = "--route" if index in routes else "extras.lutbake.route"
            if route == "runtime":
                _to_runtime_table(parts, by)
            elif route == "bake":  # forced: the bake keeps it even where it misses its target (exit 1 then)
                for info in parts.record["parts"].values():
                    info.update(route="bake", route_by=by)
            materials += parts.materials
            for name in reader.unbaked_extensions():
                notes.setdefault(name, []).append(reader.label)
        records.append(record)
    return records, materials, notes


def _no_interference_note(records: list[dict[str, Any]]) -> list[str]:
    """One line naming the used materials with a part whose film term is zero (none: no line)."""
    idle = [f"materials[{r['gltf_index']}] {str(r['name'] or '')!r}" for r in records if r.get("zero_term")]
    if not idle:
        return []
    return [
        f"{len(idle)} iridescent material{'s' if len(idle) > 1 else ''} with a part that has nothing to bake (a "
        f"film of the ambient's index on a base of it: vacuum over vacuum, its film term is 0; served as the "
        f"constant 0, no LUT): " + ", ".join(idle)
    ]


_ROUTES = ("runtime", "bake")


def _routes(values: Sequence[str], asset: GltfAsset) -> dict[int, str]:
    """{glTF material index: route} from 'NAME or INDEX=runtime|bake' strings."""
    by_name = {m.get("name"): i for i, m in enumerate(asset.materials)}
    routes: dict[int, str] = {}
    for value in values:
        key, _, route = value.rpartition("=")
        index = int(key) if key.isdigit() else by_name.get(key)
        if route not in _ROUTES or index is None or index >= len(asset.materials):
            raise ParameterError(
                "{routes} {value} is not allowed: MATERIAL=runtime or MATERIAL=bake, MATERIAL a glTF material's "
                "name or index in {asset}",
                value=repr(value),
                asset=asset.path.name,
            )
        routes[index] = route
    return routes


def _to_runtime_table(parts: _Parts, by: str) -> None:
    """Serve each part of ``parts`` from the runtime table (``route: runtime``, not baked), as ``by`` asks; a
    named metal has no (η3, κ3) for the table and stays baked (warned)."""
    for info in parts.record["parts"].values():
        if info.get("mapping") == "named":
            parts.reader.warn(f"{by} runtime: the named metal {info['named']!r} has no (η3, κ3) for it: baked")
            continue
        info.update(route="runtime", route_by=by)
        unbaked = set(served_materials(info))
        parts.materials = [m for m in parts.materials if m.name not in unbaked]


def _metal_mapping(value: str, asset: GltfAsset) -> tuple[str, dict[int, str], Path | None]:
    """(default mapping, {material index: lutbake material name}, the mapping file or None)."""
    if value in MAPPINGS:
        return value, {}, None
    path = Path(value)
    if not path.is_file():
        raise ValueError(
            f"metal mapping {value!r} is not allowed: use {' or '.join(MAPPINGS)}, or a JSON file "
            "naming a lutbake material per glTF material"
        )
    mapping = read_metal_mapping(path)
    by_name = {m["name"]: i for i, m in enumerate(asset.materials) if isinstance(m.get("name"), str)}
    named: dict[int, str] = {}
    for key, name in mapping.materials.items():
        index = int(key) if key.isascii() and key.isdigit() and len(key) <= 9 else by_name.get(key)
        if index is None or index >= len(asset.materials):
            raise ValueError(f"{path}: materials.{key}: no such glTF material in {asset.path.name}")
        named[index] = _named_metal(name, f"{path}: materials.{key}")
    return mapping.default, named, path


def _named_metal(name: object, where: str) -> str:
    if not isinstance(name, str):
        raise ValueError(f"{where} = {name!r} is not a lutbake material name")
    try:
        named_material(name)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    return name


class _MaterialReader:
    """One glTF material's values, with defaults flagged and every value checked where it is read."""

    def __init__(self, asset: GltfAsset, index: int, body: dict[str, Any], ext: dict[str, Any]):
        self.asset, self.index, self.body, self.ext = asset, index, body, ext
        self.label = f"materials[{index}] {str(body.get('name', ''))!r}"
        self.read: dict[str, object] = {}  # key -> {value, default} (a texture: whether present)
        self.warnings: list[str] = []

    def error(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.asset.path}: {self.label}: {key} {message}")

    def warn(self, message: str) -> None:
        self.warnings.append(f"{self.label}: {message}")

    def number(self, parent: dict[str, Any], key: str, default: float, where: str) -> float:
        value = parent.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise self.error(f"{where}{key}", f"= {value!r} is not a number")
        self.read[key] = {"value": value, "default": key not in parent}
        return float(value)

    def texture(self, parent: dict[str, Any], key: str, where: str) -> bool:
        if key not in parent:
            self.read[key] = False
            return False
        info = parent[key]
        if not isinstance(info, dict):
            raise self.error(f"{where}{key}", f"must be a textureInfo object, not {type(info).__name__}")
        self.asset.index(info.get("index"), len(self.asset.textures), f"{self.label}: {where}{key}.index", "textures")
        self.read[key] = True
        return True

    def unbaked_extensions(self) -> list[str]:
        """The extensions on this material that change what the film sits on or lies under and that lutbake
        does not bake (KHR_materials_specular's textures among them)."""
        exts = self.body.get("extensions", {})
        found = [e for e in (*OTHER_LAYERS, *EXCLUDED) if e in exts]
        specular = exts.get(SPECULAR)
        if isinstance(specular, dict) and any(self.read.get(k) for k in SPECULAR_TEXTURES):
            found.append("specular textures")
        return found

    def extras_route(self) -> str | None:
        """``extras.lutbake.route``: 'runtime', 'bake' or None."""
        extras = self.body.get("extras", {})
        lutbake = extras.get("lutbake", {}) if isinstance(extras, dict) else {}
        route = lutbake.get("route") if isinstance(lutbake, dict) else None
        if route is not None and route not in _ROUTES:
            raise self.error("extras.lutbake.route", f"= {route!r} is not 'runtime' or 'bake'")
        return route

    def extras_metal(self) -> str | None:
        extras = self.body.get("extras", {})
        lutbake = extras.get("lutbake", {}) if isinstance(extras, dict) else {}
        name = lutbake.get("metal") if isinstance(lutbake, dict) else None
        return None if name is None else _named_metal(name, f"{self.asset.path}: {self.label}: extras.lutbake.metal")

    def record(self, used_by: list[str]) -> dict[str, Any]:
        """What was read (defaults flagged), the film and thickness, and why nothing is baked if so."""
        ext, where = self.ext, f"{_EXT}."
        for key in ext:
            if key in _DRAFT_KEYS:
                self.warn(f"{key} is the draft spelling of {_DRAFT_KEYS[key]}: ignored, as current readers do")
            elif key not in _KNOWN_KEYS:
                self.warn(f"unknown key {_EXT}.{key}: ignored")
        factor = self.number(ext, "iridescenceFactor", FILM_DEFAULTS["iridescenceFactor"], where)
        eta2 = self.number(ext, "iridescenceIor", FILM_DEFAULTS["iridescenceIor"], where)
        d_min = self.number(ext, "iridescenceThicknessMinimum", FILM_DEFAULTS["iridescenceThicknessMinimum"], where)
        d_max = self.number(ext, "iridescenceThicknessMaximum", FILM_DEFAULTS["iridescenceThicknessMaximum"], where)
        self.texture(ext, "iridescenceTexture", where)
        textured = self.texture(ext, "iridescenceThicknessTexture", where)
        if not 0.0 <= factor <= 1.0:
            self.warn(f"iridescenceFactor {factor:g} is outside [0, 1]: engines clamp it; the film is baked as read")
        if eta2 < 1.0:
            self.warn(f"iridescenceIor {eta2:g} is below the extension's minimum 1: baked as read")
        self._domain("eta2", eta2, f"{where}iridescenceIor")
        thickness = tuple(sorted((d_min, d_max))) if textured else (d_max, d_max)
        for key, d in (("iridescenceThicknessMinimum", d_min), ("iridescenceThicknessMaximum", d_max)):
            if textured or key.endswith("Maximum"):
                self._domain("thickness_nm", d, f"{where}{key}")
        if textured and d_min > d_max:
            self.warn(f"iridescenceThicknessMinimum {d_min:g} > Maximum {d_max:g}: the range is baked sorted")
        self.thickness_key = (
            "iridescenceThicknessMinimum" if textured and d_min > d_max else "iridescenceThicknessMaximum"
        )
        record: dict[str, Any] = {
            "gltf_index": self.index,
            "name": self.body.get("name"),
            "used_by": used_by,
            "read": self.read,
            "film": None,
            "thickness_nm": list(thickness),
            "parts": {},
            "warnings": self.warnings,
        }
        if not used_by:
            record["why_not"] = "not used by any mesh primitive (nor through KHR_materials_variants)"
        elif factor == 0.0:
            given = "" if "iridescenceFactor" in ext else " (its default: omitted)"
            record["why_not"] = f"iridescenceFactor 0{given}: the extension has no effect, no film"
        else:
            record["film"] = eta2
        return record

    def _domain(self, name: str, value: float, key: str) -> None:
        """Refuse a value outside lutbake's input domain for ``name`` (points.check_value), naming ``key``."""
        try:
            check_value(name, value)
        except ValueError as exc:
            message = str(exc)
            raise self.error(key, f"= {value!r} {message[message.index('is not allowed') :]}") from None


class _Parts:
    """The scene materials serving one glTF material: a dielectric part and a metal part, as its
    metalness needs them; ``record['parts']`` says which scene material serves each."""

    def __init__(self, reader: _MaterialReader, record: dict[str, Any], named: str | None, default: str):
        self.reader, self.record = reader, record
        body, pbr_where = reader.body, "pbrMetallicRoughness."
        pbr = reader.asset.object(body, "pbrMetallicRoughness", reader.label)
        metallic = reader.number(pbr, "metallicFactor", 1.0, pbr_where)
        colour = self._base_colour(pbr)
        metal_textured = reader.texture(pbr, "metallicRoughnessTexture", pbr_where)
        colour_textured = reader.texture(pbr, "baseColorTexture", pbr_where)
        extensions = reader.asset.object(body, "extensions", reader.label)
        ior_ext = reader.asset.object(extensions, "KHR_materials_ior", f"{reader.label}.extensions")
        specular = reader.asset.object(extensions, SPECULAR, f"{reader.label}.extensions")
        ior = reader.number(ior_ext, "ior", 1.5, "KHR_materials_ior.")
        metalness = (0.0 if metal_textured else min(max(metallic, 0.0), 1.0), min(max(metallic, 0.0), 1.0))
        record["metalness"] = list(metalness)
        self.stem = _material_stem(reader.index, body.get("name"))
        self.thickness = tuple(record["thickness_nm"])
        self.materials: list[SceneMaterial] = []
        if metalness[0] < 1.0:
            self._keep("dielectric", self._dielectric(ior, specular if SPECULAR in extensions else None))
        if metalness[1] > 0.0:
            self._keep("metal", self._metal(colour, colour_textured, named, default))

    def _keep(self, part: str, info: dict[str, Any]) -> None:
        """Record ``part``; a part whose every interface is index-matched (a film of the ambient's index on a
        base of it, every channel) reflects nothing: its film term is the constant 0, served without a bake."""
        eta3 = info.get("eta3", [info["base"][0]] * 3 if "base" in info else None)
        kappa3 = info.get("kappa3", [info["base"][1]] * 3 if "base" in info else None)
        matched = [_AMBIENT_INDEX, *(eta3 or [None])]
        if self.record["film"] == _AMBIENT_INDEX and set(matched) == {_AMBIENT_INDEX} and not any(kappa3 or [1]):
            self.materials = [m for m in self.materials if m.name not in served_materials(info)]
            info = {**info, "constant": [0.0, 0.0, 0.0]}
            self.record["zero_term"] = f"the {part} part: vacuum over vacuum, film term 0 (nothing to bake)"
        self.record["parts"][part] = info

    def _dielectric(self, ior: float, specular: dict[str, Any] | None) -> dict[str, Any]:
        """The dielectric part: base η3 = ior, or (KHR_materials_specular, or ior 0) per channel the real index
        whose F0 under air is the film term's base F0 (extensions.dielectric_f0)."""
        reader, field = self.reader, "KHR_materials_ior.ior"
        if 0.0 < ior < 1.0:
            reader.warn(f"KHR_materials_ior.ior {ior:g}: valid values are 0 or at least 1; baked as read")
        if specular is None and ior != 0.0:
            reader._domain("eta3", ior, field)
            return {"base": [ior, 0.0], "material": self._add("dielectric", (ior, 0.0), "ior")}
        where = f"{SPECULAR}."
        weight = reader.number(specular or {}, "specularFactor", 1.0, where)
        colour = self._factor(specular or {}, "specularColorFactor", [1.0, 1.0, 1.0], where)
        for key in SPECULAR_TEXTURES:
            reader.texture(specular or {}, key, where)
        if ior != 0.0 and weight == 1.0 and colour == [1.0, 1.0, 1.0]:  # the ior's own F0: its index exactly
            reader._domain("eta3", ior, field)
            return {"base": [ior, 0.0], "material": self._add("dielectric", (ior, 0.0), "ior")}
        f0 = dielectric_f0(ior, weight, colour)
        eta, kappa, clamped = conductor(f0, "threejs")  # η = (1 + √F0)/(1 − √F0), κ = 0: the spec's Fresnel0ToIor
        self._report_clamp(f0, clamped, "dielectric F0")
        channels = self._channels("dielectric", eta, kappa, f"{SPECULAR} and KHR_materials_ior")
        if len(set(channels)) == 1:
            return {"base": [float(eta[0]), 0.0], "material": channels[0], "f0": f0}
        return {"f0": f0, "eta3": eta.tolist(), "kappa3": kappa.tolist(), "channels": channels}

    def _base_colour(self, pbr: dict[str, Any]) -> list[float]:
        value = self._factor(pbr, "baseColorFactor", [1.0, 1.0, 1.0, 1.0], "pbrMetallicRoughness.")
        return [min(max(v, 0.0), 1.0) for v in value[:3]]

    def _factor(self, parent: dict[str, Any], key: str, default: list[float], where: str) -> list[float]:
        """A colour factor of ``len(default)`` numbers (recorded in ``read``, its default flagged)."""
        value = parent.get(key, default)
        ok = (
            isinstance(value, list)
            and len(value) == len(default)
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value)
        )
        if not ok:
            raise self.reader.error(f"{where}{key}", f"= {value!r} is not {len(default)} numbers")
        self.reader.read[key] = {"value": value, "default": key not in parent}
        return [float(v) for v in value]

    def _add(self, part: str, base: Base, field: str, base_path: BasePath | None = None) -> str:
        name = f"{self.stem}-{part}"
        origin = {
            "film": f"{self.reader.asset.path}: {self.reader.label}: {_EXT}.iridescenceIor",
            "thickness_nm": f"{self.reader.asset.path}: {self.reader.label}: {_EXT}.{self.reader.thickness_key}",
            "base": f"{self.reader.asset.path}: {self.reader.label}: {field}",
        }
        self.materials.append(SceneMaterial(name, self.record["film"], self.thickness, base, origin, base_path))
        return name

    def _metal(self, f0: list[float], textured: bool, named: str | None, mapping: str) -> dict[str, Any]:
        if named is not None:
            if textured:
                self.reader.warn(f"baseColorTexture does not change the named metal {named!r}")
            channels = [self._add("metal", named, "named metal")] * 3
            return {"mapping": "named", "named": named, "f0": f0, "channels": channels}
        if textured:
            return self._metal_range(f0, mapping)
        eta, kappa, clamped = conductor(f0, mapping)
        self._report_clamp(f0, clamped, f"{mapping} mapping")
        channels = self._channels("metal", eta, kappa, "pbrMetallicRoughness.baseColorFactor")
        return {
            "mapping": mapping,
            "f0": f0,
            "eta3": eta.tolist(),
            "kappa3": kappa.tolist(),
            "clamped": bool(clamped.any()),
            "channels": channels,
            "reflectance_error_max": max(
                reflectance_error(float(e), float(k), min(f, F0_MAX[mapping]))["max"] for e, k, f in zip(eta, kappa, f0)
            ),
        }

    def _channels(self, part: str, eta: np.ndarray, kappa: np.ndarray, field: str) -> list[str]:
        """The scene material serving each channel's base (η3[c], κ3[c]): one for equal bases, else
        ``<part>-r|g|b``."""
        names: dict[tuple[float, float], str] = {}
        for c, key in enumerate(zip(eta, kappa)):
            if key not in names:
                name = part if len(set(zip(eta, kappa))) == 1 else f"{part}-{'rgb'[c]}"
                names[key] = self._add(name, (float(key[0]), float(key[1])), field)
        return [names[key] for key in zip(eta, kappa)]

    def _metal_range(self, f0_factor: list[float], mapping: str) -> dict[str, Any]:
        """A texture-driven base colour: F0 per channel anywhere in [0, factor]; one 4D job over the
        (η3, κ3) box the mapping's curve reaches there, and the curve as a table for the engine."""
        top = min(max(f0_factor), F0_MAX[mapping])
        self._report_clamp(f0_factor, np.asarray(f0_factor) > F0_MAX[mapping], f"{mapping} mapping")
        nodes = np.linspace(0.0, top, METAL_TABLE_NODES)
        eta, kappa, _ = conductor(nodes, mapping)
        ranges = ((float(eta.min()), float(eta.max())), (float(kappa.min()), float(kappa.max())))
        box: Base = ranges
        if ranges[0][0] == ranges[0][1] and ranges[1][0] == ranges[1][1]:  # a black texture range: one constant base
            box = (ranges[0][0], ranges[1][0])
        # The curve's nodes and how far along it each channel's F0 reaches (the scoring of its 4D job).
        path = (
            None
            if isinstance(box[0], float)
            else (tuple(eta), tuple(kappa), tuple(min(f, F0_MAX[mapping]) / top for f in f0_factor))
        )
        name = self._add("metal", box, "pbrMetallicRoughness.baseColorTexture", path)
        return {
            "mapping": mapping,
            "texture": True,
            "f0_max": [min(f, F0_MAX[mapping]) for f in f0_factor],
            "channels": [name] * 3,
            "table": {"f0": nodes.tolist(), "eta3": eta.tolist(), "kappa3": kappa.tolist()},
        }

    def _report_clamp(self, f0: list[float], clamped: np.ndarray, what: str) -> None:
        """Warn where F0 was clamped (``what``: '<mapping> mapping' for a metal, 'dielectric F0')."""
        if np.any(clamped):
            metal = what.endswith("mapping")
            top = F0_MAX[what.split()[0]] if metal else F0_MAX["threejs"]
            base = "base colour F0 up to {:g} has no finite conductor" if metal else "dielectric F0 up to {:g} has "
            base += "" if metal else "no index in lutbake's domain (η3 ≤ 10)"
            self.reader.warn(f"{base.format(max(f0))}: clamped to {top:.4g} ({what})")


def _baked(part: dict[str, Any]) -> bool:
    """Whether a part is served by the bake (not the runtime table, not a constant)."""
    return part.get("route") != "runtime" and "constant" not in part


def _material_stem(index: int, name: object) -> str:
    """'m<index>' and the glTF name as far as it is an identifier (ASCII, '-' for the rest), ≤ 40 chars."""
    slug = re.sub(r"[^A-Za-z0-9_]+", "-", str(name or "")).strip("-")[:30]
    return f"m{index}-{slug}" if slug else f"m{index}"


def material_rows(scene: Scene, plan: ScenePlan) -> list[dict[str, Any]]:
    """`plan --gltf --json`: per glTF material with KHR_materials_iridescence, what it read (defaults
    flagged), its film, thickness range and bases, the mapping, and ``slice`` (the name `lutbake sample
    ATLAS --material` accepts: the dielectric part's, else the metal's) or ``lut`` (a 4D job's file), or
    ``why_not``."""
    kind = {name: job for job in plan.jobs for name in job.materials}
    assert scene.source is not None  # a glTF scene's
    rows = []
    for r in scene.source["materials"]:
        parts = r["parts"]
        served = [name for part in parts.values() if _baked(part) for name in served_materials(part)]
        runtime = [name for name, part in parts.items() if part.get("route") == "runtime"]
        slices = [n for n in dict.fromkeys(served) if kind[n].kind == "slice"]
        luts = [f"{kind[n].id}.exr" for n in dict.fromkeys(served) if kind[n].kind == "lut"]
        rows.append(
            {
                "gltf_index": r["gltf_index"],
                "name": r["name"],
                "used_by": r["used_by"],
                "read": r["read"],
                "defaults": sorted(k for k, v in r["read"].items() if isinstance(v, dict) and v["default"]),
                "film": r["film"],
                "thickness_nm": r["thickness_nm"],
                "metalness": r.get("metalness"),
                "bases": parts,
                "mapping": parts.get("metal", {}).get("mapping"),
                "slice": slices[0] if slices else None,
                "slices": slices,
                "lut": luts[0] if luts else None,
                "runtime_parts": runtime,
                "routes": planned_routes(r),
                "why_not": r.get("why_not")
                or (f"served by the runtime table: {', '.join(runtime)}" if runtime else None)
                or (None if slices or luts else r.get("zero_term")),
                "warnings": r["warnings"],
            }
        )
    return rows
