"""Scene manifests (TOML) and their plans: the materials a scene uses, validated (docs/scene.md), and
the jobs that serve them.

Plan: materials with a fixed base (constant or a named dispersive material)
need only a 2D slice over (cos θ, film thickness), one thickness row when
the thickness is fixed; materials that share film, thickness range and base
share a slice. Only a base given as η3/κ3 ranges (texture-driven) needs a
4D LUT, over just those ranges. Baking the plan is atlas.py's.

Errors name the file, the line and the field: ``scene.toml:12: materials.steel.base.kappa3 = -1 is
not allowed: must be a finite number >= 0``.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .colorimetry import OBSERVERS, SPACES
from .lutfile import shader_ident
from .materials import material
from .plan import Axis, BakeSpec
from .points import FilmPoints, check_value, dielectric_film
from .refine import TUNE_START_COUNTS
from .slices import SliceStack

__all__ = ["Scene", "SceneMaterial", "load_scene", "SceneJob", "ScenePlan", "plan_scene", "truth_rate", "MAX_SLICE_COUNT", "HELD_OUT_POINTS",
           "TRUTH_TOLERANCE"]

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


# --- plan -------------------------------------------------------------------------------------

MAX_SLICE_COUNT = 256  # per slice axis: 256 × 256 texels, 384 KiB in half
# Held-out ground-truth points a job is scored at: the bulk of a scene bake's time (the grids
# themselves go through the bake's integrator). A 4D job's final bake adds its ≤ 112 probes.
HELD_OUT_POINTS = {"slice": 160, "lut": 300}
_LUT_PROBES = 112
# Held-out truth converged to |ΔRGB| ≤ 1e-5: ~300× below the colour step of the finest target a scene
# may set (ΔE00 0.01 is ~3e-3 in RGB at its most sensitive). Tighter costs seconds at near-grazing
# points (Airy dips narrower than the 1 nm panels), where 1e-7 needs 2048 nodes per nm.
TRUTH_TOLERANCE = 1e-5


@dataclass
class SceneJob:
    """A 2D (cos θ, thickness) slice or a 4D LUT serving one or more materials."""

    kind: str                 # "slice" or "lut"
    key: dict
    materials: list
    scene: Scene = field(repr=False)
    counts: tuple = ()

    @property
    def hash(self) -> str:
        return self.scene.hash_of(self.kind, self.key)

    @property
    def id(self) -> str:
        return f"{self.kind}-{self.hash[:12]}"

    @property
    def thickness_nm(self) -> tuple:
        return tuple(self.key["thickness_nm"])

    @property
    def fixed_thickness(self) -> bool:
        return self.thickness_nm[0] == self.thickness_nm[1]

    def stack(self) -> SliceStack:
        """A slice's fixed film stack."""
        return SliceStack(self.scene.eta1, self.key["film"], self.key["base"])

    def film_index_550(self) -> float:
        film = self.key["film"]
        return float(material(film).index(550.0)[0]) if isinstance(film, str) else float(film)

    def bytes_estimate(self, counts=None) -> int:
        per_texel = 6 if self.scene.precision == "half" else 12
        return int(np.prod(counts or self.counts)) * per_texel

    def lut_spec(self) -> BakeSpec:
        """A ranged-base job's 4D domain (a fixed thickness is widened to a 2-node D axis)."""
        eta2 = float(self.key["film"])
        d_lo, d_hi = _widen(*(2 * eta2 * t for t in self.thickness_nm))
        (e_lo, e_hi), (k_lo, k_hi) = (_widen(*r) for r in self.key["base"])
        axes = (Axis("cos_theta", 0.0, 1.0, 32, "sqrt"), Axis("opd_nm", d_lo, d_hi, 128),
                Axis("eta3", e_lo, e_hi, 16), Axis("kappa3", k_lo, k_hi, 16, "sqrt"))
        s = self.scene
        return BakeSpec(eta2=eta2, eta1=s.eta1, axes=axes, space=s.space, observer=s.observer, precision=s.precision)


def _widen(lo, hi):
    return (lo, hi) if hi > lo else (lo, lo + 1e-6 * max(1.0, abs(lo)))


@dataclass
class ScenePlan:
    scene: Scene
    jobs: list

    def describe(self, seconds_per_truth_point=None) -> dict:
        """Jobs, axes, starting counts and bytes (slices grow until their target holds); with a
        measured ``seconds_per_truth_point`` (``truth_rate``), each job's ground-truth seconds."""
        rows = []
        for job in self.jobs:
            row = {"id": job.id, "kind": job.kind, "materials": job.materials, "counts": list(job.counts),
                   "bytes_start": job.bytes_estimate()}
            if job.kind == "slice":
                row["axes"] = {"cos_theta": [0.0, 1.0, "sqrt"], "thickness_nm": job.key["thickness_nm"]}
                row["bytes_max"] = job.bytes_estimate((MAX_SLICE_COUNT, 1 if job.fixed_thickness else MAX_SLICE_COUNT))
            else:
                row["axes"] = [{k: v for k, v in a.describe().items() if k != "count"} for a in job.lut_spec().axes]
            if seconds_per_truth_point is not None:
                row["truth_seconds_estimate"] = seconds_per_truth_point * _truth_points(job)
            rows.append(row)
        from .bake import default_specs

        generic = next(iter(default_specs().values())).cells * (6 if self.scene.precision == "half" else 12)
        return {"scene": self.scene.file_name, "settings": self.scene.settings_key(), "jobs": rows,
                "bytes_start_total": sum(r["bytes_start"] for r in rows), "generic_4d_bytes": generic}


def _initial_counts(job: SceneJob) -> tuple:
    if job.kind == "lut":
        return tuple(2 if i == 1 and job.fixed_thickness else c for i, c in enumerate(TUNE_START_COUNTS))
    if job.fixed_thickness:
        return 16, 1
    lo, hi = job.thickness_nm
    # Colour cycles once per ~400 nm of D = 2·η2·d; ~12 nodes per cycle.
    cycles = 2.0 * job.film_index_550() * (hi - lo) / 400.0
    return 16, int(np.clip(np.ceil(12 * cycles) + 1, 8, MAX_SLICE_COUNT))


def plan_scene(scene: Scene) -> ScenePlan:
    """The jobs a scene needs: one per distinct (kind, film, thickness, base), in material order.

    A fixed base needs a 2D slice over (cos θ, thickness) ('slice'); a base given as η3/κ3 ranges needs
    a 4D LUT over just those ranges ('lut'). Materials that share film, thickness and base share a job.

    Examples
    --------
    >>> import lutbake
    >>> _ = open("films.toml", "w").write('''
    ... [materials.soap]
    ... film = 1.33
    ... thickness_nm = [200, 600]
    ... base = 1.0
    ... [materials.bubble]
    ... film = 1.33
    ... thickness_nm = [200, 600]
    ... base = 1.0
    ... [materials.coating]
    ... film = 1.5
    ... thickness_nm = [100, 400]
    ... base = { eta3 = [1.2, 2.0], kappa3 = [0.0, 1.0] }
    ... ''')
    >>> [(job.kind, job.materials) for job in lutbake.plan_scene(lutbake.load_scene("films.toml")).jobs]
    [('slice', ['soap', 'bubble']), ('lut', ['coating'])]
    """
    jobs = {}
    for m in scene.materials:
        kind = "lut" if m.base_is_range else "slice"
        key = m.slice_key()
        ident = json.dumps([kind, key], sort_keys=True)
        if ident not in jobs:
            jobs[ident] = SceneJob(kind, key, [], scene)
        jobs[ident].materials.append(m.name)
    out = list(jobs.values())
    for job in out:
        job.counts = _initial_counts(job)
    return ScenePlan(scene, out)


def _truth_points(job: SceneJob) -> int:
    return HELD_OUT_POINTS[job.kind] + (_LUT_PROBES if job.kind == "lut" else 0)


def truth_rate(plan: ScenePlan, points: int = 16) -> float:
    """Seconds per ground-truth point, measured now on this machine over a sample of each job's
    domain (colour tables are built by an untimed warm-up first)."""
    from .reference import reference_colour

    rng = np.random.default_rng(0)

    def sample(job, n):
        cos_t, d = rng.uniform(0.0, 1.0, n) ** 2, rng.uniform(*job.thickness_nm, n)
        if job.kind == "slice":
            pts = job.stack().points(cos_t, d)
        else:
            (e_lo, e_hi), (k_lo, k_hi) = job.key["base"]
            pts = FilmPoints.build(eta1=job.scene.eta1, eta2=float(job.key["film"]), cos_theta=cos_t,
                                   thickness_nm=d, eta3=rng.uniform(e_lo, e_hi, n), kappa3=rng.uniform(k_lo, k_hi, n))
        reference_colour(pts, job.scene.observer, job.scene.space, tolerance=TRUTH_TOLERANCE)

    for job in plan.jobs:
        sample(job, 2)
    start = time.perf_counter()
    for job in plan.jobs:
        sample(job, points)
    return (time.perf_counter() - start) / (points * max(len(plan.jobs), 1))
