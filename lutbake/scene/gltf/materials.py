"""The glTF scene source: KHR_materials_iridescence materials of a glTF asset, mapped to the scene
model (docs/gltf.md).

Every material with KHR_materials_iridescence that a mesh primitive uses (directly or through
KHR_materials_variants) is mapped; unused ones are listed, not baked. The mapping, recorded per
material in the manifest's ``source`` section:

* ambient η1 = 1; film η2 = iridescenceIor exactly (default 1.3, never snapped); thickness the range
  [min, max] (sorted: the spec allows min > max) when iridescenceThicknessTexture is present, else
  iridescenceThicknessMaximum (default 400 nm); iridescenceFactor 0: no film, nothing baked (the
  factor and iridescenceTexture only blend the film term in the engine);
* the dielectric part (metalness < 1 somewhere): base η3 = ior (KHR_materials_ior, default 1.5);
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
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.physics.materials import material as named_material
from lutbake.physics.metals import F0_MAX, MAPPINGS, conductor, reflectance_error
from lutbake.physics.points import check_value
from lutbake.scene.gltf.asset import GltfAsset, read_gltf
from lutbake.scene.gltf.mapping import read_metal_mapping
from lutbake.scene.model import Base, BasePath, Scene, SceneMaterial, check_material_names

if TYPE_CHECKING:
    from lutbake.scene.plan import ScenePlan

__all__ = ["load_gltf_scene", "METAL_TABLE_NODES", "FILM_DEFAULTS"]

_EXT = "KHR_materials_iridescence"
FILM_DEFAULTS = {
    "iridescenceFactor": 1.0,
    "iridescenceIor": 1.3,
    "iridescenceThicknessMinimum": 100.0,
    "iridescenceThicknessMaximum": 400.0,
}
_KNOWN_KEYS = set(FILM_DEFAULTS) | {"iridescenceTexture", "iridescenceThicknessTexture", "extensions", "extras"}
_DRAFT_KEYS = {"iridescenceIOR": "iridescenceIor"}
METAL_TABLE_NODES = 65  # F0 → (η3, κ3) nodes the engine interpolates for a texture-driven metal


def load_gltf_scene(path: str | PathLike[str], metal_mapping: str = "fitted", max_de: float = 1.0) -> Scene:
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
    >>> film = {"KHR_materials_iridescence": {"iridescenceIor": 1.33, "iridescenceThicknessMaximum": 380}}
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
    records, materials = _iridescent_materials(asset, named, default)
    check_material_names([m.name for m in materials], lambda name, message: asset.error(name, message))
    max_de = float(check_value("max_de", max_de)[0])
    source = {
        "kind": "gltf",
        "asset": asset.path.name,
        "metal_mapping": default,
        "mapping_file": None if mapping_file is None else Path(mapping_file).name,
        "asset_warnings": asset.warnings,
        "materials": records,
    }
    inputs = () if mapping_file is None else (str(mapping_file),)
    return Scene(str(asset.path), "rec709", "cie1931", 1.0, "half", max_de, tuple(materials), source, inputs)


def _iridescent_materials(
    asset: GltfAsset, named: dict[int, str], default: str
) -> tuple[list[dict[str, Any]], list[SceneMaterial]]:
    """(the record of every glTF material with the iridescence extension, the scene materials of those
    the meshes use and that have a film), in the asset's order; a metal base mapped by ``named`` (index →
    lutbake material), else by the material's extras, else by ``default``."""
    used = asset.used_materials()
    records: list[dict[str, Any]] = []
    materials: list[SceneMaterial] = []
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
            materials += parts.materials
        records.append(record)
    return records, materials


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
            record["why_not"] = "iridescenceFactor 0: no film"
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
        ior_ext = reader.asset.object(
            reader.asset.object(body, "extensions", reader.label), "KHR_materials_ior", f"{reader.label}.extensions"
        )
        ior = reader.number(ior_ext, "ior", 1.5, "KHR_materials_ior.")
        metalness = (0.0 if metal_textured else min(max(metallic, 0.0), 1.0), min(max(metallic, 0.0), 1.0))
        record["metalness"] = list(metalness)
        self.stem = _material_stem(reader.index, body.get("name"))
        self.thickness = tuple(record["thickness_nm"])
        self.materials: list[SceneMaterial] = []
        if metalness[0] < 1.0:
            reader._domain("eta3", ior, "KHR_materials_ior.ior")
            record["parts"]["dielectric"] = {"base": [ior, 0.0], "material": self._add("dielectric", (ior, 0.0), "ior")}
        if metalness[1] > 0.0:
            record["parts"]["metal"] = self._metal(colour, colour_textured, named, default)

    def _base_colour(self, pbr: dict[str, Any]) -> list[float]:
        value = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
        ok = (
            isinstance(value, list)
            and len(value) == 4
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in value)
        )
        if not ok:
            raise self.reader.error("pbrMetallicRoughness.baseColorFactor", f"= {value!r} is not 4 numbers")
        self.reader.read["baseColorFactor"] = {"value": value, "default": "baseColorFactor" not in pbr}
        return [min(max(float(v), 0.0), 1.0) for v in value[:3]]

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
            return {"mapping": "named", "named": named, "channels": [self._add("metal", named, "named metal")] * 3}
        if textured:
            return self._metal_range(f0, mapping)
        eta, kappa, clamped = conductor(f0, mapping)
        self._report_clamp(f0, clamped, mapping)
        names: dict[tuple[float, float], str] = {}
        channels: list[str] = []
        for c, key in enumerate(zip(eta, kappa)):
            if key not in names:
                part = "metal" if len(set(zip(eta, kappa))) == 1 else f"metal-{'rgb'[c]}"
                names[key] = self._add(part, (float(key[0]), float(key[1])), "pbrMetallicRoughness.baseColorFactor")
            channels.append(names[key])
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

    def _metal_range(self, f0_factor: list[float], mapping: str) -> dict[str, Any]:
        """A texture-driven base colour: F0 per channel anywhere in [0, factor]; one 4D job over the
        (η3, κ3) box the mapping's curve reaches there, and the curve as a table for the engine."""
        top = min(max(f0_factor), F0_MAX[mapping])
        self._report_clamp(f0_factor, np.asarray(f0_factor) > F0_MAX[mapping], mapping)
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

    def _report_clamp(self, f0: list[float], clamped: np.ndarray, mapping: str) -> None:
        if np.any(clamped):
            self.reader.warn(
                f"base colour F0 up to {max(f0):g} has no finite conductor: clamped to "
                f"{F0_MAX[mapping]:.4g} ({mapping} mapping)"
            )


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
        served = [parts["dielectric"]["material"]] if "dielectric" in parts else []
        served += parts["metal"]["channels"] if "metal" in parts else []
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
                "why_not": r.get("why_not"),
                "warnings": r["warnings"],
            }
        )
    return rows
