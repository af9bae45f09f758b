"""Scene bakes (`bake --scene`): a scene plan's slices and 4D LUTs as one file set.

Each slice is integrated by the bake's integrator (slices.py) and grown by
the refinement engine (refine.py) until its p99 ΔE00 at held-out points,
measured on the values as the atlas stores them and against the
independent ground truth (reference.py), meets the scene's target; each
ranged-base job is tuned the same way (refine.tune) and baked as a 4D LUT.
Slices are packed into one atlas EXR, with a JSON manifest and GLSL and HLSL
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
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .bake import lut_members, write_lut
from .batch import fast_colours
from .colorimetry import delta_e00
from .errors import ParameterError
from .fileset import FileSet, open_set, sha256_file
from .lutfile import (ATLAS_FORMAT, atlas_includes, atomic_path, pack_atlas, warn_texture_size, write_atlas,
                      write_text_atomic)
from .integrate import backend as make_backend
from .materials import material
from .points import FilmPoints
from .progress import no_progress
from .reference import reference_colour
from .refine import Trial, refine, tune
from .sample import Atlas
from .scene import HELD_OUT_POINTS, MAX_SLICE_COUNT, TRUTH_TOLERANCE, Scene, SceneJob, plan_scene
from .slices import integrate_slice

__all__ = ["bake_scene", "check_scene_outputs", "scene_outputs"]

_HELD_OUT = HELD_OUT_POINTS["slice"]
_LUT_MAX_ROUNDS = 6


# --- slices ------------------------------------------------------------------------------------

def _held_out(job: SceneJob, seed: int = 0):
    """(film stacks, truth RGB) at uniform points in √cos θ and thickness: the independent ground truth."""
    rng = np.random.default_rng(seed)
    cos_t = rng.uniform(0.0, 1.0, _HELD_OUT) ** 2
    d = rng.uniform(*job.thickness_nm, _HELD_OUT)
    pts = job.stack().points(cos_t, d)
    return pts, reference_colour(pts, job.scene.observer, job.scene.space, tolerance=TRUTH_TOLERANCE).values


def _slice_measure(job: SceneJob, held_out, integrator):
    """``refine``'s measure for a slice: integrated, rounded to the atlas's precision, sampled at the
    held-out points by the atlas sampler (sample.Atlas) and scored there."""
    pts, truth = held_out
    s, stack = job.scene, job.stack()  # one stack: it keeps what it learns about its materials' spectra
    stored = np.float16 if s.precision == "half" else np.float32

    def measure(counts, label):
        start = time.perf_counter()
        values = integrate_slice(stack, counts, job.thickness_nm, integrator, s.observer, s.space)
        seconds = time.perf_counter() - start
        image = values.astype(stored)
        rect = {**_slice_meta(job, [0, 0, counts[0], counts[1]]), "materials": ["slice"]}
        rgb = Atlas({"eta1": s.eta1, "slices": [rect]}, image).sample("slice", pts)
        p99 = float(np.percentile(delta_e00(rgb, truth, s.observer, s.space), 99))
        return Trial(counts, p99, image.nbytes, seconds), values

    return measure


def refine_slice(job: SceneJob, integrator, held_out) -> tuple:
    """The slice grown until its stored values, scored at ``held_out`` (``_held_out``), meet the
    scene's p99 target: (values, cache record)."""
    frozen = (1,) if job.fixed_thickness else ()
    result = refine(_slice_measure(job, held_out, integrator), job.counts, job.scene.max_de, frozen=frozen,
                    cap=MAX_SLICE_COUNT)
    meta = {"counts": list(result.counts), "de00_p99": result.best.de00_p99, "held_out_points": _HELD_OUT,
            "constant_index_de00_p99": constant_index_error(job, held_out, integrator)}
    return result.artefact, meta


def constant_index_error(job: SceneJob, held_out, integrator) -> float | None:
    """p99 ΔE00 if the slice's named materials were taken at their 550 nm index (what a
    constant-index LUT would show), at the held-out points; None without named materials."""
    film, base = job.key["film"], job.key["base"]
    if not isinstance(film, str) and not isinstance(base, str):
        return None
    held, truth = held_out
    eta3, kappa3 = ((float(v) for v in material(base).index(550.0)) if isinstance(base, str) else base)
    pts = FilmPoints.build(eta1=job.scene.eta1, eta2=job.film_index_550(), cos_theta=held.cos_theta,
                           thickness_nm=held.thickness_nm, eta3=eta3, kappa3=kappa3)
    approx = fast_colours(pts, job.scene.observer, job.scene.space, integrator)[0]  # constant indices: the kernel
    return float(np.percentile(delta_e00(approx, truth, job.scene.observer, job.scene.space), 99))


# --- 4D LUTs for ranged bases ------------------------------------------------------------------

def _tuned_lut(job: SceneJob, path: Path, backend: str, files: FileSet) -> dict:
    """Bake the 4D LUT at the smallest counts (refine.tune) whose p99 ΔE00 meets the target."""
    spec = job.lut_spec()
    result = tune(spec, job.scene.max_de, n_points=HELD_OUT_POINTS["lut"], seed=0, backend=backend,
                  max_rounds=_LUT_MAX_ROUNDS, start=job.counts, frozen=(1,) if job.fixed_thickness else ())
    axes = tuple(replace(a, count=c) for a, c in zip(spec.axes, result.counts))
    write_lut(replace(spec, axes=axes), path, files, backend)
    return {"counts": list(result.counts), "de00_p99": result.best.de00_p99, "target_met": result.met,
            "sha256": sha256_file(files.members[path])}


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
    device: str | None = None  # the integrator's device, when a job was computed


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


def _slice_paths(cache: Path, job) -> tuple:
    return cache / f"{job.id}.npy", cache / f"{job.id}.json"


def _compute_slice(job, cache: Path, integrator, held_out) -> tuple:
    """(values, meta) refined now and written to the cache."""
    values, meta = refine_slice(job, integrator(), held_out)
    npy, info = _slice_paths(cache, job)
    with atomic_path(npy) as tmp, open(tmp, "wb") as fh:
        np.save(fh, values)  # a file handle: np.save would append ".npy" to the temporary's name
    write_text_atomic(info, json.dumps(meta, indent=2) + "\n")
    return values, meta


def _cached_lut(path: Path, info_path: Path):
    """The cache record of a 4D LUT whose set is complete and whose EXR has the recorded hash, else None."""
    try:
        info = _record(info_path)
        ok = all(p.is_file() for p in lut_members(path)) and sha256_file(path) == info["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return info if ok else None


def scene_outputs(out: Path, scene: Scene, plan) -> dict:
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
            raise ParameterError("{out_dir} {out}: {path} is a folder, expected a file or nothing",
                                 out=repr(str(out)), path=repr(str(path)))
    cache = out / ".lutbake-cache"
    if cache.exists() and not cache.is_dir():
        raise ParameterError("{out_dir} {out}: {path} is a file, expected the cache folder",
                             out=repr(str(out)), path=repr(str(cache)))


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
    """Bake what ``scene`` needs into ``out_dir`` as one file set.

    Slices go into one atlas (NAME.exr, .json manifest, .glsl/.hlsl includes with the material table);
    each 4D job into its own LUT. Each job grows until its p99 ΔE00 at held-out points, measured on
    the stored values, meets the scene's ``max_de``. Unchanged jobs come from ``out_dir``'s cache; an
    unchanged scene writes nothing.

    Parameters
    ----------
    scene : Scene
        From ``load_scene``.
    out_dir : str or os.PathLike
        Folder for the file set (created if absent).
    force : bool
        Recompute every job, ignoring the cache.
    backend : str
        'auto', 'opencl' or 'numpy' (see ``bake_lut``).
    progress : callable
        ``progress(done, total, note)`` before each job.

    Returns
    -------
    SceneResult
        Files written, jobs computed and reused, whether it was up to date, wall seconds, materials whose
        target was not met (with the p99 reached), the device.

    Examples
    --------
    >>> import lutbake
    >>> _ = open("films.toml", "w").write('''
    ... [materials.soap]
    ... film = 1.33
    ... thickness_nm = [200, 600]
    ... base = 1.0
    ... ''')
    >>> scene = lutbake.load_scene("films.toml")
    >>> first = lutbake.bake_scene(scene, "baked")
    >>> sorted(p.name for p in first.written), first.unmet
    (['films.exr', 'films.glsl', 'films.hlsl', 'films.json'], {})
    >>> lutbake.bake_scene(scene, "baked").up_to_date
    True
    >>> atlas = lutbake.Atlas.load("baked/films.exr")
    >>> soap = lutbake.FilmPoints.build(**atlas.film_stack("soap"), cos_theta=[1.0, 0.5], thickness_nm=300.0)
    >>> atlas.sample("soap", soap).shape
    (2, 3)
    """
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
        slice_jobs = [job for job in plan.jobs if job.kind == "slice"]
        cached = {job.id: None if force else _cached_slice(*_slice_paths(cache, job)) for job in slice_jobs}
        # Two workers: the device's start-up and the slices' held-out ground truths (numpy, which
        # releases the GIL) run side by side, and the truths go on while the first slices refine.
        with ThreadPoolExecutor(max_workers=2) as pool:
            integrator = _Device(pool, backend)
            if any(v is None for v in cached.values()):
                integrator.start()
            truths = {job.id: pool.submit(_held_out, job) for job in slice_jobs if cached[job.id] is None}
            slices, entries = [], {}
            for done, job in enumerate(plan.jobs):
                progress(done, len(plan.jobs), f"{job.id} ({job.kind}: {', '.join(job.materials)})")
                if job.kind == "slice":
                    if cached[job.id] is None:
                        values, info = _compute_slice(job, cache, integrator, truths[job.id].result())
                        computed.append(job.id)
                    else:
                        values, info = cached[job.id]
                        reused.append(job.id)
                    slices.append((job, values, info))
                    continue
                info = _scene_lut(job, out, cache, force, backend, files, computed, reused)
                for name in job.materials:
                    entries[name] = {"kind": "lut", "job": job.id, "file": f"{job.id}.exr", "counts": info["counts"],
                                     "de00_p99": info["de00_p99"], "sample": "lutbake_sample (docs/lut-format.md)"}
            device = integrator().device if computed else None
        atlas = pack_atlas([values for _, values, _ in slices])
        warn_texture_size(atlas["width"], atlas["height"], outputs["atlas"].name if slices else stem)
        if slices:
            exr_path = outputs["atlas"]
            meta = {"format": ATLAS_FORMAT, "format_version": 1, "scene_hash": scene_hash,
                    "space": scene.space, "observer": scene.observer, "encoding": "linear",
                    "precision": scene.precision, "eta1": scene.eta1,
                    "slices": [_slice_meta(j, rect) for (j, _, _), rect in zip(slices, atlas["rects"])]}
            write_atlas(files.temp(exr_path), atlas, meta, scene.precision)
            for (job, values, info), rect in zip(slices, atlas["rects"]):
                for name in job.materials:
                    entries[name] = _slice_entry(job, info, rect, atlas, exr_path.name)
        manifest = {"format": "lutbake-scene-manifest", "format_version": 1, "scene": scene.file_name,
                    "scene_hash": scene_hash, "settings": scene.settings_key(),
                    "materials": {m.name: entries[m.name] for m in scene.materials}}
        for lang, text in atlas_includes(manifest, atlas).items():
            files.temp(outputs[lang]).write_text(text)
        manifest["files"] = {p.name: sha256_file(files.members.get(p, p))
                             for p in outputs.values() if p != outputs["manifest"]}
        files.temp(outputs["manifest"]).write_text(json.dumps(manifest, indent=2) + "\n")
        written = sorted(files.members)
    return SceneResult(out, written, computed, reused, False, time.perf_counter() - start,
                       _unmet(manifest["materials"], scene.max_de), device)


class _Device:
    """The scene's integrator, made once and only when a job is computed (none when every job comes
    from the cache). ``start()`` makes it on ``pool``'s worker thread: the device's start-up
    (kernel build and self-check, one core) then overlaps what the bake does meanwhile."""

    def __init__(self, pool, backend: str):
        self.pool, self.backend, self.made = pool, backend, None

    def start(self):
        if self.made is None:
            self.made = self.pool.submit(make_backend, self.backend)

    def __call__(self):
        self.start()
        return self.made.result()


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
