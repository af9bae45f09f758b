"""Scene bakes: the smallest set of LUTs that serves a scene's materials (`plan`, `bake --scene`).

Plan: materials with a fixed base (constant or a named dispersive material)
need only a 2D slice over (cos θ, film thickness) — one thickness row when the
thickness is fixed; materials that share film, thickness range and base share
a slice. Only a base given as η3/κ3 ranges (texture-driven) needs a 4D LUT,
over just those ranges. Slices are integrated by the ground truth
(reference.py: exact for dispersive indices, wavelength by wavelength) and
refined until their p99 ΔE00 at held-out points meets the scene's target;
they are packed into one atlas EXR, with a JSON manifest and GLSL and HLSL
includes holding the material table.

Incremental: each slice and LUT is keyed by a content hash. An unchanged
scene writes nothing; a changed material recomputes only its slice (the
others come from DIR/.lutbake-cache, each entry checked for shape and
finiteness and recomputed when it fails); --force recomputes all. The
atlas, includes, 4D LUTs and manifest are one file set (fileset.py): the
manifest records every member's SHA-256, and "up to date" means the
manifest's scene hash and every member's hash match.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .bake import lut_members, write_lut
from .colorimetry import delta_e00
from .fileset import FileSet, open_set, sha256_file
from .lutfile import (ATLAS_FORMAT, atomic_path, exr_rows, shader_ident, shader_template, warn_texture_size,
                      write_text_atomic)
from .materials import material
from .plan import Axis, BakeSpec
from .points import FilmPoints
from .progress import no_progress
from .reference import reference_colour
from .scene import Scene
from .sweep import TUNE_START_COUNTS, tune

__all__ = ["ScenePlan", "plan_scene", "bake_scene"]

_MAX_COUNT = 256
_HELD_OUT = 160
# Slice nodes and held-out truth to |ΔRGB| ≤ 1e-7: 10⁴× below the interpolation error that matters.
_SLICE_TOLERANCE = 1e-7


@dataclass
class SliceJob:
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

    def film_index_550(self) -> float:
        film = self.key["film"]
        return float(material(film).index(550.0)[0]) if isinstance(film, str) else float(film)

    def bytes_estimate(self, counts=None) -> int:
        per_texel = 6 if self.scene.precision == "half" else 12
        return int(np.prod(counts or self.counts)) * per_texel


@dataclass
class ScenePlan:
    scene: Scene
    jobs: list

    def describe(self, seconds_per_truth_point=None) -> dict:
        """Jobs, axes, counts, bytes; with a measured ``seconds_per_truth_point`` (see
        ``truth_rate``), each job's time as a [low, high] range from its ground-truth work."""
        rows = []
        for job in self.jobs:
            row = {"id": job.id, "kind": job.kind, "materials": job.materials, "counts": list(job.counts),
                   "bytes_start": job.bytes_estimate()}
            if job.kind == "slice":
                row["axes"] = {"cos_theta": [0.0, 1.0, "sqrt"], "thickness_nm": job.key["thickness_nm"]}
                row["bytes_max"] = job.bytes_estimate((_MAX_COUNT, _MAX_COUNT if job.counts[1] > 1 else 1))
            else:
                spec = lut_spec(job)
                row["axes"] = [{k: v for k, v in a.describe().items() if k != "count"} for a in spec.axes]
            if seconds_per_truth_point is not None:
                row["seconds_estimate"] = [seconds_per_truth_point * n for n in _truth_points(job)]
            rows.append(row)
        generic = 32 * 128 * 16 * 16 * (6 if self.scene.precision == "half" else 12)
        return {"scene": self.scene.file_name, "settings": self.scene.settings_key(), "jobs": rows,
                "bytes_start_total": sum(r["bytes_start"] for r in rows), "generic_4d_bytes": generic}


# Ground-truth points a tuned LUT job evaluates: tune's held-out points, then per trial bake the
# spectral-error probes (48) and the capped-texel probes (≤ 64); 6 bakes at the least (start, one
# round, final), 31 at the most (6 rounds of 4 trials, trims, final).
_LUT_TRUTH_POINTS = (300 + 6 * 112, 300 + 31 * 112)


def _truth_points(job: SliceJob) -> tuple:
    """(fewest, most) ground-truth points the job evaluates: the bulk of its time."""
    if job.kind == "lut":
        return _LUT_TRUTH_POINTS
    held_out = 2 * _HELD_OUT  # the slice's held-out truth, and the constant-index comparison
    counts, most = job.counts, int(np.prod(job.counts))
    while max(counts) < _MAX_COUNT:  # refine_slice doubles one axis per round up to the cap
        grow_d = counts[1] > 1 and counts[1] <= 2 * counts[0]
        counts = (counts[0], 2 * counts[1]) if grow_d else (2 * counts[0], counts[1])
        most += int(np.prod(counts))
    return held_out + int(np.prod(job.counts)), held_out + most


def truth_rate(plan: ScenePlan, points: int = 32) -> float:
    """Seconds per ground-truth point, measured now on this machine over a sample of each job's
    range (colour tables and rules are built by an untimed warm-up first)."""
    rng = np.random.default_rng(0)
    for job in plan.jobs:
        _sample_truth(job, rng, 2)
    start = time.perf_counter()
    for job in plan.jobs:
        _sample_truth(job, rng, points)
    return (time.perf_counter() - start) / (points * max(len(plan.jobs), 1))


def _sample_truth(job: SliceJob, rng, n: int) -> None:
    cos_t, d = rng.uniform(0.0, 1.0, n) ** 2, rng.uniform(*job.key["thickness_nm"], n)
    if job.kind == "slice":
        _truth(job, cos_t, d)
        return
    (e_lo, e_hi), (k_lo, k_hi) = job.key["base"]
    pts = FilmPoints.build(eta1=job.scene.eta1, eta2=float(job.key["film"]), cos_theta=cos_t, thickness_nm=d,
                           eta3=rng.uniform(e_lo, e_hi, n), kappa3=rng.uniform(k_lo, k_hi, n))
    reference_colour(pts, job.scene.observer, job.scene.space)


def _initial_counts(scene: Scene, key: dict, film_index: float) -> tuple:
    lo, hi = key["thickness_nm"]
    if hi == lo:
        return 16, 1
    # Colour cycles once per ~400 nm of D = 2·η2·d; ~12 nodes per cycle.
    cycles = 2.0 * film_index * (hi - lo) / 400.0
    return 16, int(np.clip(np.ceil(12 * cycles) + 1, 8, _MAX_COUNT))


def plan_scene(scene: Scene) -> ScenePlan:
    jobs = {}
    for m in scene.materials:
        kind = "lut" if m.base_is_range else "slice"
        key = m.slice_key()
        ident = json.dumps([kind, key], sort_keys=True)
        if ident not in jobs:
            jobs[ident] = SliceJob(kind, key, [], scene)
        jobs[ident].materials.append(m.name)
    out = list(jobs.values())
    for job in out:
        job.counts = (_initial_counts(scene, job.key, job.film_index_550()) if job.kind == "slice"
                      else TUNE_START_COUNTS)
    return ScenePlan(scene, out)


# --- slices ------------------------------------------------------------------------------------

def _slice_axes(job: SliceJob, counts) -> tuple:
    lo, hi = job.key["thickness_nm"]
    return Axis("cos_theta", 0.0, 1.0, counts[0], "sqrt"), (lo, hi, counts[1])


def _slice_points(job: SliceJob, cos_theta, thickness_nm) -> FilmPoints:
    film, base = job.key["film"], job.key["base"]
    kw = {"film": film} if isinstance(film, str) else {"eta2": film}
    kw.update({"base": base} if isinstance(base, str) else {"eta3": base[0], "kappa3": base[1]})
    return FilmPoints.build(eta1=job.scene.eta1, cos_theta=cos_theta, thickness_nm=thickness_nm, **kw)


def _truth(job: SliceJob, cos_theta, thickness_nm) -> np.ndarray:
    pts = _slice_points(job, cos_theta, thickness_nm)
    return reference_colour(pts, job.scene.observer, job.scene.space, tolerance=_SLICE_TOLERANCE).values


def _thickness_values(lo, hi, n):
    return np.array([lo]) if n == 1 else np.linspace(lo, hi, n)


def compute_slice(job: SliceJob, counts) -> np.ndarray:
    """Ground-truth colours on the slice grid, (n_thickness, n_cos, 3)."""
    cos_axis, (lo, hi, n_d) = _slice_axes(job, counts)
    cos_t, d = np.meshgrid(cos_axis.values(), _thickness_values(lo, hi, n_d))
    return _truth(job, cos_t.ravel(), d.ravel()).reshape(n_d, counts[0], 3)


def sample_slice(values, job: SliceJob, cos_theta, thickness_nm) -> np.ndarray:
    """Bilinear in (√cos θ, thickness) node coordinates, clamped: what the atlas shader does."""
    n_d, n_cos, _ = values.shape
    cos_axis, (lo, hi, _) = _slice_axes(job, (n_cos, n_d))
    fx = np.clip(cos_axis.to_unit(cos_theta), 0, 1) * (n_cos - 1)
    fy = np.zeros_like(fx) if n_d == 1 else np.clip((np.asarray(thickness_nm) - lo) / (hi - lo), 0, 1) * (n_d - 1)
    x0 = np.minimum(np.floor(fx), n_cos - 2).astype(int)
    y0 = np.minimum(np.floor(fy), max(n_d - 2, 0)).astype(int)
    y1 = np.minimum(y0 + 1, n_d - 1)
    tx, ty = (fx - x0)[:, None], (fy - y0)[:, None]
    top = values[y0, x0] * (1 - tx) + values[y0, x0 + 1] * tx
    bottom = values[y1, x0] * (1 - tx) + values[y1, x0 + 1] * tx
    return top * (1 - ty) + bottom * ty


def _held_out(job: SliceJob, seed: int = 0):
    rng = np.random.default_rng(seed)
    lo, hi = job.key["thickness_nm"]
    cos_t = rng.uniform(0.0, 1.0, _HELD_OUT) ** 2
    d = rng.uniform(lo, hi, _HELD_OUT)
    return cos_t, d, _truth(job, cos_t, d)


def refine_slice(job: SliceJob) -> tuple:
    """Grow the slice until its p99 ΔE00 at held-out points meets the target: (values, counts, p99)."""
    cos_t, d, truth = _held_out(job)
    counts = job.counts
    while True:
        values = compute_slice(job, counts)
        de = delta_e00(sample_slice(values, job, cos_t, d), truth, job.scene.observer, job.scene.space)
        p99 = float(np.percentile(de, 99))
        if p99 <= job.scene.max_de or max(counts) >= _MAX_COUNT:
            return values, counts, p99, (cos_t, d, truth)
        # Grow the axis the error follows: thickness while fringes dominate, else angle.
        grow_d = counts[1] > 1 and counts[1] <= 2 * counts[0]
        counts = (counts[0], min(2 * counts[1], _MAX_COUNT)) if grow_d else (min(2 * counts[0], _MAX_COUNT), counts[1])


def constant_index_error(job: SliceJob, held_out) -> float | None:
    """p99 ΔE00 if the slice's named materials were taken at their 550 nm index (what a
    constant-index LUT would show), at the held-out points; None without named materials."""
    film, base = job.key["film"], job.key["base"]
    if not isinstance(film, str) and not isinstance(base, str):
        return None
    cos_t, d, truth = held_out
    eta2 = job.film_index_550()
    eta3, kappa3 = ((float(v) for v in material(base).index(550.0)) if isinstance(base, str) else base)
    pts = FilmPoints.build(eta1=job.scene.eta1, eta2=eta2, cos_theta=cos_t, thickness_nm=d, eta3=eta3, kappa3=kappa3)
    approx = reference_colour(pts, job.scene.observer, job.scene.space, tolerance=_SLICE_TOLERANCE).values
    return float(np.percentile(delta_e00(approx, truth, job.scene.observer, job.scene.space), 99))


# --- 4D LUTs for ranged bases ------------------------------------------------------------------

def _widen(lo, hi):
    return (lo, hi) if hi > lo else (lo, lo + 1e-6 * max(1.0, abs(lo)))


def _tuned_lut(job: SliceJob, path: Path, backend: str, files: FileSet) -> dict:
    """Bake the 4D LUT at the smallest counts (sweep.tune) whose p99 ΔE00 meets the target."""
    spec = lut_spec(job)
    result = tune(spec, job.scene.max_de, n_points=300, seed=0, backend=backend, max_rounds=6)
    axes = tuple(replace(a, count=c) for a, c in zip(spec.axes, result["counts"]))
    write_lut(replace(spec, axes=axes), path, files, backend)
    return {"counts": result["counts"], "de00_p99": result["result"]["de00_p99"], "target_met": result["met"],
            "sha256": sha256_file(files.members[path])}


def lut_spec(job: SliceJob) -> BakeSpec:
    eta2 = float(job.key["film"])
    d_lo, d_hi = _widen(*(2 * eta2 * t for t in job.key["thickness_nm"]))
    (e_lo, e_hi), (k_lo, k_hi) = (_widen(*r) for r in job.key["base"])
    d_count = 2 if job.key["thickness_nm"][0] == job.key["thickness_nm"][1] else 128
    axes = (Axis("cos_theta", 0.0, 1.0, 32, "sqrt"), Axis("opd_nm", d_lo, d_hi, d_count),
            Axis("eta3", e_lo, e_hi, 16), Axis("kappa3", k_lo, k_hi, 16, "sqrt"))
    s = job.scene
    return BakeSpec(eta2=eta2, eta1=s.eta1, axes=axes, space=s.space, observer=s.observer, precision=s.precision)


# --- bake --------------------------------------------------------------------------------------

@dataclass
class SceneResult:
    out_dir: Path
    written: list
    computed: list
    reused: list
    up_to_date: bool
    seconds: float
    unmet: dict = field(default_factory=dict)  # material -> p99 ΔE00 reached, where above the target


def _cache(out: Path) -> Path:
    path = out / ".lutbake-cache"
    path.mkdir(exist_ok=True)
    return path


def _record(path: Path) -> dict:
    """A cache record (JSON) with integer counts and a finite p99; raises OSError, ValueError, KeyError
    or TypeError otherwise."""
    info = json.loads(path.read_text())
    info["counts"] = [int(c) for c in info["counts"]]
    if not np.isfinite(float(info["de00_p99"])):
        raise ValueError("de00_p99")
    return info


def _cached_slice(npy: Path, info: Path):
    """(values, meta) of a cache entry that matches its recorded counts and is finite, else None."""
    try:
        meta = _record(info)
        n_cos, n_d = meta["counts"]
        values = np.load(npy, allow_pickle=False)
    except (OSError, ValueError, EOFError, KeyError, TypeError):
        return None
    if values.shape != (n_d, n_cos, 3) or not np.isfinite(values).all():
        return None
    return values, meta


def _load_or_compute_slice(job, cache: Path, force: bool, computed, reused):
    npy, info = cache / f"{job.id}.npy", cache / f"{job.id}.json"
    cached = None if force else _cached_slice(npy, info)
    if cached is not None:
        reused.append(job.id)
        return cached
    values, counts, p99, held_out = refine_slice(job)
    meta = {"counts": list(counts), "de00_p99": p99, "held_out_points": _HELD_OUT,
            "constant_index_de00_p99": constant_index_error(job, held_out)}
    with atomic_path(npy) as tmp, open(tmp, "wb") as fh:
        np.save(fh, values)  # a file handle: np.save would append ".npy" to the temporary's name
    write_text_atomic(info, json.dumps(meta, indent=2) + "\n")
    computed.append(job.id)
    return values, meta


def _cached_lut(path: Path, info_path: Path):
    """The cache record of a 4D LUT whose set is complete and whose EXR has the recorded hash, else None."""
    try:
        info = _record(info_path)
        ok = all(p.is_file() for p in lut_members(path)) and sha256_file(path) == info["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return info if ok else None


def scene_outputs(out: Path, scene: Scene, plan: ScenePlan) -> dict:
    """Role -> path of every file of the scene's set (4D LUTs by job id)."""
    stem = Path(scene.path).stem
    paths = {"manifest": out / f"{stem}.json", "glsl": out / f"{stem}.glsl", "hlsl": out / f"{stem}.hlsl"}
    if any(j.kind == "slice" for j in plan.jobs):
        paths["atlas"] = out / f"{stem}.exr"
    for job in plan.jobs:
        if job.kind == "lut":
            paths.update({f"{job.id}{p.suffix}": p for p in lut_members(out / f"{job.id}.exr")})
    return paths


def check_scene_outputs(out: Path, scene: Scene) -> None:
    """Refuse before any write when an output or the cache path is taken by the wrong kind of entry."""
    for path in scene_outputs(out, scene, plan_scene(scene)).values():
        if path.is_dir():
            raise ValueError(f"--out {str(out)!r}: {str(path)!r} is a folder, expected a file or nothing")
    cache = out / ".lutbake-cache"
    if cache.exists() and not cache.is_dir():
        raise ValueError(f"--out {str(out)!r}: {str(cache)!r} is a file, expected the cache folder")


def _up_to_date(manifest_path: Path, scene_hash: str, outputs: dict) -> bool:
    """The manifest is this scene's and every member it lists exists with the recorded hash."""
    try:
        manifest = json.loads(manifest_path.read_text())
        files = manifest["files"]
        if manifest["scene_hash"] != scene_hash or sorted(files) != sorted(p.name for p in outputs.values()
                                                                           if p != manifest_path):
            return False
        return all(sha256_file(manifest_path.parent / name) == digest for name, digest in files.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def bake_scene(scene: Scene, out_dir, force: bool = False, backend: str = "auto",
               progress=no_progress) -> SceneResult:
    """Bake what ``scene`` needs into ``out_dir`` as one file set; ``progress(done, total, note)``
    before each job."""
    start = time.perf_counter()
    out = Path(out_dir)
    check_scene_outputs(out, scene)
    out.mkdir(parents=True, exist_ok=True)
    stem = Path(scene.path).stem
    plan = plan_scene(scene)
    scene_hash = scene.hash_of([job.hash for job in plan.jobs], [m.name for m in scene.materials])
    outputs = scene_outputs(out, scene, plan)
    with open_set(out, f"scene-{stem}") as files:
        if not force and _up_to_date(outputs["manifest"], scene_hash, outputs):
            entries = json.loads(outputs["manifest"].read_text())["materials"]
            return SceneResult(out, [], [], [j.id for j in plan.jobs], True, time.perf_counter() - start,
                               _unmet(entries, scene.max_de))
        cache, computed, reused = _cache(out), [], []
        slices, entries = [], {}
        for done, job in enumerate(plan.jobs):
            progress(done, len(plan.jobs), f"{job.id} ({job.kind}: {', '.join(job.materials)})")
            if job.kind == "slice":
                values, info = _load_or_compute_slice(job, cache, force, computed, reused)
                slices.append((job, values, info))
                continue
            info = _scene_lut(job, out, cache, force, backend, files, computed, reused)
            for name in job.materials:
                entries[name] = {"kind": "lut", "job": job.id, "file": f"{job.id}.exr", "counts": info["counts"],
                                 "de00_p99": info["de00_p99"], "sample": "lutbake_sample (docs/lut-format.md)"}
        atlas = _pack(slices)
        warn_texture_size(atlas["width"], atlas["height"], outputs["atlas"].name if slices else stem)
        if slices:
            exr_path = outputs["atlas"]
            meta = {"format": ATLAS_FORMAT, "format_version": 1, "scene_hash": scene_hash,
                    "space": scene.space, "observer": scene.observer, "encoding": "linear",
                    "precision": scene.precision, "eta1": scene.eta1,
                    "slices": [_slice_meta(j, rect) for (j, _, _), rect in zip(slices, atlas["rects"])]}
            with exr_rows(files.temp(exr_path), atlas["width"], atlas["height"], meta, scene.precision) as exr:
                exr.write_rows(atlas["image"])
            for (job, values, info), rect in zip(slices, atlas["rects"]):
                for name in job.materials:
                    entries[name] = _slice_entry(job, info, rect, atlas, exr_path.name)
        manifest = {"format": "lutbake-scene-manifest", "format_version": 1, "scene": scene.file_name,
                    "scene_hash": scene_hash, "settings": scene.settings_key(),
                    "materials": {m.name: entries[m.name] for m in scene.materials}}
        for lang in _SHADER:
            files.temp(outputs[lang]).write_text(_shader(manifest, atlas, lang))
        manifest["files"] = {p.name: sha256_file(files.members.get(p, p))
                             for p in outputs.values() if p != outputs["manifest"]}
        files.temp(outputs["manifest"]).write_text(json.dumps(manifest, indent=2) + "\n")
        written = sorted(files.members)
    return SceneResult(out, written, computed, reused, False, time.perf_counter() - start,
                       _unmet(manifest["materials"], scene.max_de))


def _unmet(entries: dict, max_de: float) -> dict:
    """Materials whose p99 ΔE00 stayed above the target at the resolution cap."""
    return {name: e["de00_p99"] for name, e in entries.items() if e["de00_p99"] > max_de}


def _scene_lut(job, out: Path, cache: Path, force: bool, backend: str, files: FileSet, computed, reused):
    """The cache record of a ranged-base 4D LUT: reused when intact, else tuned and written."""
    path, info_path = out / f"{job.id}.exr", cache / f"{job.id}.json"
    info = None if force else _cached_lut(path, info_path)
    if info is not None:
        reused.append(job.id)
    else:
        info = _tuned_lut(job, path, backend, files)
        write_text_atomic(info_path, json.dumps(info, indent=2) + "\n")
        computed.append(job.id)
    return info


def _slice_meta(job, rect) -> dict:
    """What the atlas header says about a slice: enough to sample it by material name."""
    x0, y0, w, h = rect
    lo, hi = job.key["thickness_nm"]
    return {"id": job.id, "rect": rect, "materials": job.materials,
            "axes": {"cos_theta": {"min": 0.0, "max": 1.0, "count": w, "spacing": "sqrt"},
                     "thickness_nm": {"min": lo, "max": hi, "count": h, "spacing": "uniform"}},
            "film": job.key["film"], "base": job.key["base"]}


def _slice_entry(job, info, rect, atlas, exr_name) -> dict:
    x0, y0, w, h = rect
    entry = {k: v for k, v in _slice_meta(job, rect).items() if k not in ("id", "materials")}
    return {"kind": "slice", "job": job.id, "file": exr_name, **entry,
            "uv_rect": [x0 / atlas["width"], y0 / atlas["height"], (x0 + w) / atlas["width"], (y0 + h) / atlas["height"]],
            "de00_p99": info["de00_p99"], "constant_index_de00_p99": info["constant_index_de00_p99"],
            "sample": "lutbake_atlas_sample(atlas, LUTBAKE_<SCENE>_<MATERIAL>, cos_theta, thickness_nm)"}


def _pack(slices) -> dict:
    """Stack slices vertically, left-aligned: each a rect of texels; sampling stays inside it."""
    if not slices:
        return {"width": 0, "height": 0, "rects": [], "image": None}
    width = max(v.shape[1] for _, v, _ in slices)
    height = sum(v.shape[0] for _, v, _ in slices)
    image = np.zeros((height, width, 3))
    rects, y = [], 0
    for _, v, _ in slices:
        image[y:y + v.shape[0], :v.shape[1]] = v
        rects.append([0, y, v.shape[1], v.shape[0]])
        y += v.shape[0]
    return {"width": width, "height": height, "rects": rects, "image": image}


_SHADER = {
    "glsl": ("const LutbakeSlice {ident} = LutbakeSlice(vec4({rect}), vec2({thick}), vec2({size}));",
             "// {name}: 4D LUT {file} (sample it with {stem}.glsl)"),
    "hlsl": ("static const LutbakeSlice {ident} = {{float4({rect}), float2({thick}), float2({size})}};",
             "// {name}: 4D LUT {file} (sample it with {stem}.hlsl)"),
}


def _shader(manifest: dict, atlas: dict, lang: str) -> str:
    """The scene's atlas sampler and one LutbakeSlice constant per material, in GLSL or HLSL."""
    slice_line, lut_line = _SHADER[lang]
    scene = Path(manifest["scene"]).stem
    size = ", ".join(str(float(v)) for v in (atlas["width"], atlas["height"]))
    lines = []
    for name, e in manifest["materials"].items():
        if e["kind"] == "slice":
            th = e["axes"]["thickness_nm"]
            lines.append(slice_line.format(ident=shader_ident(f"{scene}_{name}"), size=size,
                                           rect=", ".join(str(float(v)) for v in e["rect"]),
                                           thick=f"{float(th['min'])}, {float(th['max'])}"))
        else:
            lines.append(lut_line.format(name=name, file=e["file"], stem=Path(e["file"]).stem))
    return shader_template(f"atlas.{lang}.in").substitute(
        scene=manifest["scene"], scene_hash=manifest["scene_hash"][:16], atlas=f"{scene}.exr",
        materials="\n".join(lines))
