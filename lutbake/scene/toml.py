"""The scene source lutbake defines: a TOML scene file (docs/scene.md), read into the scene model.

Errors name the file, the line and the field: ``scene.toml:12: materials.steel.base.kappa3 = -1 is
not allowed: must be a number in [0, 1000]``. The text is read with a byte bound and its nesting is
checked before it is parsed (lutbake/io/documents.py); each material's ``origin`` points at its table's lines,
found only when a message needs them (a scan per field would make 10^5 materials quadratic).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Collection
from os import PathLike
from pathlib import Path
from typing import Any

from lutbake.io.documents import load_toml, read_text
from lutbake.physics.colorimetry import OBSERVERS, SPACES
from lutbake.physics.materials import material
from lutbake.physics.points import check_value, dielectric_film, inside_domain
from lutbake.scene.model import Base, Film, Scene, SceneMaterial, check_material_names

__all__ = ["load_scene", "MAX_SCENE_BYTES"]

# A scene file is hand-written: 64 MiB holds ~10^6 materials, far beyond any real scene.
MAX_SCENE_BYTES = 64 << 20

_SCENE_KEYS = {"space", "observer", "eta1", "precision", "max_de"}
_MATERIAL_KEYS = {"film", "thickness_nm", "base"}
_BASE_KEYS = {"eta3", "kappa3"}


class _Locator:
    """Line numbers of tables and keys in the TOML text, for error messages."""

    def __init__(self, path: str, text: str):
        self.path, self.lines = path, text.splitlines()

    def line(self, table: str, key: str | None = None) -> int:
        header = re.compile(r"^\s*\[\s*" + re.escape(table).replace(r"\.", r"\s*\.\s*") + r"\s*\]")
        start = next((i for i, line in enumerate(self.lines) if header.match(line)), None)
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
        return ValueError(f"{self.where(table, key)}: {message}")

    def where(self, table: str, key: str | None = None) -> str:
        return f"{self.path}:{self.line(table, key)}"


class _Where:
    """'scene.toml:LINE: materials.NAME.FIELD', the line found when the text is first asked for."""

    def __init__(self, loc: _Locator, table: str, key: str):
        self.loc, self.table, self.key = loc, table, key

    def __str__(self) -> str:
        return f"{self.loc.where(self.table, self.key)}: {self.table}.{self.key}"


def load_scene(path: str | PathLike[str]) -> Scene:
    """Parse and validate a scene manifest (TOML, docs/scene.md).

    Parameters
    ----------
    path : str or os.PathLike
        The manifest: ``[scene]`` settings and one ``[materials.NAME]`` table per material (film index
        or name, thickness in nm as a number or [min, max], base as an index, {eta3, kappa3}, ranges of
        them, or a named material).

    Returns
    -------
    Scene
        Settings (space, observer, precision, η1, target ``max_de``) and the materials, in file order.

    Raises
    ------
    ValueError
        One line naming the file, line and field, the value and what is allowed.

    Examples
    --------
    >>> import lutbake
    >>> _ = open("films.toml", "w").write('''
    ... [materials.soap]
    ... film = 1.33
    ... thickness_nm = [200, 600]
    ... base = 1.0
    ... [materials.oxide]
    ... film = 2.9
    ... thickness_nm = 40
    ... base = "Fe"
    ... ''')
    >>> scene = lutbake.load_scene("films.toml")
    >>> [m.name for m in scene.materials], scene.max_de
    (['soap', 'oxide'], 1.0)
    """
    file = Path(path)
    if not file.is_file():
        raise ValueError(f"scene {str(file)!r} does not exist")
    text = read_text(file, "scene", MAX_SCENE_BYTES)
    loc = _Locator(str(file), text)
    doc = load_toml(text, str(file))
    unknown = set(doc) - {"scene", "materials"}
    if unknown:
        key = sorted(unknown)[0]
        raise ValueError(
            f"{file}:{_top_line(loc, key)}: unknown table or key {key!r}: allowed [scene], [materials.NAME]"
        )
    space, observer, precision, eta1, max_de = _settings(loc, doc.get("scene", {}))
    return Scene(str(file), space, observer, eta1, precision, max_de, _materials(loc, doc.get("materials", {})))


def _settings(loc: _Locator, settings: Any) -> tuple[str, str, str, float, float]:
    """The ``[scene]`` table's (space, observer, precision, η1, max_de), each defaulted where absent."""
    _no_unknown(loc, "scene", settings, _SCENE_KEYS)
    return (
        _choice(loc, "scene", "space", settings.get("space", "rec709"), SPACES),
        _choice(loc, "scene", "observer", settings.get("observer", "cie1931"), OBSERVERS),
        _choice(loc, "scene", "precision", settings.get("precision", "half"), ("float", "half")),
        _number(loc, "scene", "eta1", settings.get("eta1", 1.0), "eta1"),
        _number(loc, "scene", "max_de", settings.get("max_de", 1.0), "max_de"),
    )


def _materials(loc: _Locator, materials: Any) -> tuple[SceneMaterial, ...]:
    """The ``[materials.NAME]`` tables, each a SceneMaterial, in file order (at least one, names valid)."""
    if not isinstance(materials, dict):
        raise ValueError(
            f"{loc.path}:{_top_line(loc, 'materials')}: materials must be tables [materials.NAME], "
            f"not {type(materials).__name__}"
        )
    if not materials:
        raise loc.error("scene", None, "no materials: add at least one [materials.NAME] table")
    check_material_names(materials, lambda name, message: loc.error(f"materials.{name}", None, message))
    return tuple(_material(loc, name, body) for name, body in materials.items())


def _top_line(loc: _Locator, key: str) -> int:
    for i, line in enumerate(loc.lines):
        if re.match(r"^\s*\[?\s*" + re.escape(key) + r"\b", line):
            return i + 1
    return 1


def _no_unknown(loc: _Locator, table: str, body: Any, allowed: Collection[str]) -> None:
    if not isinstance(body, dict):
        raise loc.error(table, None, f"{table} must be a table")
    for key in body:
        if key not in allowed:
            raise loc.error(table, key, f"unknown field {table}.{key}: allowed {', '.join(sorted(allowed))}")


def _choice(loc: _Locator, table: str, key: str, value: Any, allowed: Collection[str]) -> str:
    if value not in allowed:
        raise loc.error(table, key, f"{table}.{key} = {value!r} is not one of {', '.join(allowed)}")
    return value


def _number(loc: _Locator, table: str, key: str, value: Any, domain: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise loc.error(table, key, f"{table}.{key} = {value!r} is not a number")
    if not inside_domain(domain, value):  # a scalar test: an array per value cost 10x (10^5 materials)
        try:
            check_value(domain, value)  # the same test; raises naming the value and what is allowed
        except ValueError as exc:
            raise loc.error(table, key, f"{table}.{key}: {exc}") from None
    return float(value)


def _range_or_number(loc: _Locator, table: str, key: str, value: Any, domain: str) -> tuple[float, float]:
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


def _named(loc: _Locator, table: str, key: str, name: Any, lookup: Callable[[str], object] = material) -> str:
    if not isinstance(name, str):
        raise loc.error(table, key, f"{table}.{key} = {name!r} is not a material name")
    try:
        lookup(name)
    except ValueError as exc:
        raise loc.error(table, key, f"{table}.{key}: {exc}") from None
    return name


def _material(loc: _Locator, name: str, body: Any) -> SceneMaterial:
    table = f"materials.{name}"
    _no_unknown(loc, table, body, _MATERIAL_KEYS)
    for key in ("film", "thickness_nm", "base"):
        if key not in body:
            raise loc.error(table, None, f"{table} is missing the field {key!r}")
    given_film = body["film"]
    film: Film = (
        _named(loc, table, "film", given_film, dielectric_film)
        if isinstance(given_film, str)
        else _number(loc, table, "film", given_film, "eta2")
    )
    thickness = _range_or_number(loc, table, "thickness_nm", body["thickness_nm"], "thickness_nm")
    given = body["base"]
    base: Base
    if isinstance(given, str):
        base = _named(loc, table, "base", given)
    elif isinstance(given, dict):
        sub = f"{table}.base"
        for key in given:
            if key not in _BASE_KEYS:
                raise loc.error(table, "base", f"unknown field {sub}.{key}: allowed eta3, kappa3")
        if "eta3" not in given:
            raise loc.error(table, "base", f"{sub} is missing the field 'eta3'")
        eta3 = _range_or_number(loc, table, "eta3", given["eta3"], "eta3")
        kappa3 = _range_or_number(loc, table, "kappa3", given.get("kappa3", 0.0), "kappa3")
        ranged = eta3[0] != eta3[1] or kappa3[0] != kappa3[1]
        if ranged and isinstance(film, str):
            raise loc.error(
                table, "film", f"{table}: a named (dispersive) film needs a fixed base, not eta3/kappa3 ranges"
            )
        base = (eta3, kappa3) if ranged else (eta3[0], kappa3[0])
    else:
        base = (_number(loc, table, "base", given, "eta3"), 0.0)
    origin: dict[str, object] = {key: _Where(loc, table, key) for key in _MATERIAL_KEYS}
    return SceneMaterial(name, film, thickness, base, origin)
