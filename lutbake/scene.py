"""Scene manifests (TOML): the materials a scene uses, validated (docs/scene.md).

Errors name the file, the line and the field: ``scene.toml:12: materials.steel.base.kappa3 = -1 is
not allowed: must be a finite number >= 0``.
"""

from __future__ import annotations

import hashlib
import json
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from .colorimetry import OBSERVERS, SPACES
from .lutfile import shader_ident
from .materials import material
from .points import check_value, dielectric_film

__all__ = ["Scene", "SceneMaterial", "load_scene"]

_SCENE_KEYS = {"space", "observer", "eta1", "precision", "max_de"}
_MATERIAL_KEYS = {"film", "thickness_nm", "base"}
_BASE_KEYS = {"eta3", "kappa3"}


@dataclass(frozen=True)
class SceneMaterial:
    """One material: film (η2 or a name), thickness (fixed or range, nm), base (fixed, name or ranges)."""

    name: str
    film: object            # float η2 or material name
    thickness_nm: tuple     # (lo, hi); lo == hi for a fixed thickness
    base: object            # (η3, κ3), material name, or ((η3 lo, hi), (κ3 lo, hi)) ranges

    @property
    def base_is_range(self) -> bool:
        return isinstance(self.base, tuple) and isinstance(self.base[0], tuple)

    def slice_key(self) -> dict:
        """Everything the material's pixels depend on (materials equal here share a slice)."""
        return {"film": self.film, "thickness_nm": list(self.thickness_nm),
                "base": json.loads(json.dumps(self.base))}


@dataclass(frozen=True)
class Scene:
    path: str
    space: str
    observer: str
    eta1: float
    precision: str
    max_de: float
    materials: tuple

    @property
    def file_name(self) -> str:
        """The scene file's name: what outputs record (not the path as typed, which depends on the cwd)."""
        return Path(self.path).name

    def settings_key(self) -> dict:
        return {"space": self.space, "observer": self.observer, "eta1": self.eta1,
                "precision": self.precision, "max_de": self.max_de}

    def hash_of(self, *parts) -> str:
        from . import __version__

        text = json.dumps([self.settings_key(), *parts, __version__], sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()


class _Locator:
    """Line numbers of tables and keys in the TOML text, for error messages."""

    def __init__(self, path: str, text: str):
        self.path, self.lines = path, text.splitlines()

    def line(self, table: str, key: str | None = None) -> int:
        header = re.compile(r"^\s*\[\s*" + re.escape(table).replace(r"\.", r"\s*\.\s*") + r"\s*\]")
        start = next((i for i, l in enumerate(self.lines) if header.match(l)), None)
        if start is None:
            return 1
        if key is None:
            return start + 1
        pattern = re.compile(r"^\s*" + re.escape(key) + r"\s*=|[{,]\s*" + re.escape(key) + r"\s*=")
        for i in range(start + 1, len(self.lines)):
            if self.lines[i].lstrip().startswith("["):
                break
            if pattern.search(self.lines[i]):
                return i + 1
        return start + 1

    def error(self, table: str, key: str | None, message: str) -> ValueError:
        return ValueError(f"{self.path}:{self.line(table, key)}: {message}")


def load_scene(path) -> Scene:
    """Parse and validate a scene manifest; ValueError names file, line and field."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"scene {str(path)!r} does not exist")
    text = path.read_text()
    loc = _Locator(str(path), text)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: invalid TOML: {exc}") from None
    unknown = set(doc) - {"scene", "materials"}
    if unknown:
        key = sorted(unknown)[0]
        raise ValueError(f"{path}:{_top_line(loc, key)}: unknown table or key {key!r}: allowed [scene], [materials.NAME]")
    settings = doc.get("scene", {})
    _no_unknown(loc, "scene", settings, _SCENE_KEYS)
    space = _choice(loc, "scene", "space", settings.get("space", "rec709"), SPACES)
    observer = _choice(loc, "scene", "observer", settings.get("observer", "cie1931"), OBSERVERS)
    precision = _choice(loc, "scene", "precision", settings.get("precision", "half"), ("float", "half"))
    eta1 = _number(loc, "scene", "eta1", settings.get("eta1", 1.0), "eta1")
    max_de = _number(loc, "scene", "max_de", settings.get("max_de", 1.0), "max_de")
    materials = doc.get("materials", {})
    if not isinstance(materials, dict):
        raise ValueError(f"{path}:{_top_line(loc, 'materials')}: materials must be tables [materials.NAME], "
                         f"not {type(materials).__name__}")
    if not materials:
        raise loc.error("scene", None, "no materials: add at least one [materials.NAME] table")
    _check_names(loc, list(materials))
    parsed = tuple(_material(loc, name, body) for name, body in materials.items())
    return Scene(str(path), space, observer, eta1, precision, max_de, parsed)


def _check_names(loc, names):
    """Names become shader identifiers: ASCII letters, digits, '-' and '_', distinct once sanitised."""
    seen = {}
    for name in names:
        table = f"materials.{name}"
        if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]{0,63}", name):
            raise loc.error(table, None, f"material name {name!r} is not allowed: use 1-64 ASCII letters, "
                                         "digits, '-' or '_', starting with a letter")
        ident = shader_ident(name)
        if ident in seen:
            raise loc.error(table, None, f"material names {seen[ident]!r} and {name!r} both become "
                                         f"{ident} in shaders: rename one")
        seen[ident] = name


def _top_line(loc, key):
    for i, l in enumerate(loc.lines):
        if re.match(r"^\s*\[?\s*" + re.escape(key) + r"\b", l):
            return i + 1
    return 1


def _no_unknown(loc, table, body, allowed):
    if not isinstance(body, dict):
        raise loc.error(table, None, f"{table} must be a table")
    for key in body:
        if key not in allowed:
            raise loc.error(table, key, f"unknown field {table}.{key}: allowed {', '.join(sorted(allowed))}")


def _choice(loc, table, key, value, allowed):
    if value not in allowed:
        raise loc.error(table, key, f"{table}.{key} = {value!r} is not one of {', '.join(allowed)}")
    return value


def _number(loc, table, key, value, domain):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise loc.error(table, key, f"{table}.{key} = {value!r} is not a number")
    try:
        return float(check_value(domain, value)[0])
    except ValueError as exc:
        raise loc.error(table, key, f"{table}.{key}: {exc}") from None


def _range_or_number(loc, table, key, value, domain):
    """A number, or [lo, hi] with lo <= hi; returns (lo, hi)."""
    if isinstance(value, list):
        if len(value) != 2:
            raise loc.error(table, key, f"{table}.{key} = {value!r}: a range is [lo, hi]")
        lo, hi = (_number(loc, table, key, v, domain) for v in value)
        if hi < lo:
            raise loc.error(table, key, f"{table}.{key} = {value!r} is reversed: need lo <= hi")
        return lo, hi
    v = _number(loc, table, key, value, domain)
    return v, v


def _named(loc, table, key, name, lookup=material):
    if not isinstance(name, str):
        raise loc.error(table, key, f"{table}.{key} = {name!r} is not a material name")
    try:
        lookup(name)
    except ValueError as exc:
        raise loc.error(table, key, f"{table}.{key}: {exc}") from None
    return name


def _material(loc, name, body) -> SceneMaterial:
    table = f"materials.{name}"
    _no_unknown(loc, table, body, _MATERIAL_KEYS)
    for key in ("film", "thickness_nm", "base"):
        if key not in body:
            raise loc.error(table, None, f"{table} is missing the field {key!r}")
    film = body["film"]
    film = (_named(loc, table, "film", film, dielectric_film) if isinstance(film, str)
            else _number(loc, table, "film", film, "eta2"))
    thickness = _range_or_number(loc, table, "thickness_nm", body["thickness_nm"], "thickness_nm")
    base = body["base"]
    if isinstance(base, str):
        base = _named(loc, table, "base", base)
    elif isinstance(base, dict):
        sub = f"{table}.base"
        for key in base:
            if key not in _BASE_KEYS:
                raise loc.error(table, "base", f"unknown field {sub}.{key}: allowed eta3, kappa3")
        if "eta3" not in base:
            raise loc.error(table, "base", f"{sub} is missing the field 'eta3'")
        eta3 = _range_or_number(loc, table, "eta3", base["eta3"], "eta3")
        kappa3 = _range_or_number(loc, table, "kappa3", base.get("kappa3", 0.0), "kappa3")
        ranged = eta3[0] != eta3[1] or kappa3[0] != kappa3[1]
        if ranged and isinstance(film, str):
            raise loc.error(table, "film", f"{table}: a named (dispersive) film needs a fixed base, "
                                            "not eta3/kappa3 ranges")
        base = (eta3, kappa3) if ranged else (eta3[0], kappa3[0])
    else:
        base = (_number(loc, table, "base", base, "eta3"), 0.0)
    return SceneMaterial(name, film, thickness, base)
