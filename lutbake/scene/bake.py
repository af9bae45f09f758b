"""Scene bakes (`bake --scene`, `bake --gltf`): a scene's plan run and written as one file set.

The stages, a module each: a source (lutbake/scene/toml.py, lutbake/scene/gltf/) makes the scene model
(lutbake/scene/model.py); lutbake/scene/plan.py makes its jobs; lutbake/scene/jobs.py runs them
(lutbake/scene/slices.py, lutbake/quality/refine.py); lutbake/tables/atlas.py packs the slices; this module
keeps the cache (lutbake/scene/cache.py) and writes the set: the atlas, the includes, the 4D LUTs and the
manifest, committed together (lutbake/io/fileset.py).

Incremental: unchanged jobs come from OUT/.lutbake-cache; an unchanged scene writes nothing. "Up to
date" means the manifest is unedited (its own hash), is this scene's (scene hash) and every member
it lists has the recorded SHA-256.
"""

from __future__ import annotations

import contextlib
import functools
import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.opencl import backend as make_backend
from lutbake.io.fileset import FileSet, open_set, sha256_file
from lutbake.io.manifest import MANIFEST_FORMAT, read_scene_manifest, sealed, shared_metal_tables
from lutbake.io.progress import no_progress
from lutbake.lut.bake import lut_members
from lutbake.lut.sample import Lut
from lutbake.physics.points import MAX_INDEX, MAX_OPD_NM
from lutbake.scene.cache import SceneCache
from lutbake.scene.gltf.routes import choose_routes, route_lines, source_unmet
from lutbake.scene.jobs import refine_slice, slice_atlas, tuned_lut
from lutbake.scene.model import Scene
from lutbake.scene.plan import SceneJob, ScenePlan, plan_scene
from lutbake.scene.shipping import earlier_build_artefacts, is_web_member, remove_build_artefacts, shipping
from lutbake.tables.atlas import ERROR_KEYS, atlas_header, pack_atlas, slice_entry, write_atlas
from lutbake.tables.includes import atlas_includes, warn_texture_size

if TYPE_CHECKING:
    import numpy as np

    from lutbake.scene.gltf.scoring import Sampler
    from lutbake.scene.slices import Integrator

    # ``progress(done, total, note)``: lutbake.io.progress's Meter, or no_progress.
    Progress = Callable[[int, int | None, str], None]
    # A computed or reused slice: its job, values (rows, columns, 3) and record.
    SliceResult = tuple[SceneJob, np.ndarray, dict[str, Any]]

__all__ = ["bake_scene", "check_scene_outputs", "scene_outputs", "SceneResult"]

# A film's domain for the bake's direct rule at any point (integrator.evaluate): the rule level is per point,
# the axes only bound it (η2 and the settings replaced per use).
_TRUTH_SPEC = BakeSpec(
    eta2=1.5,
    eta1=1.0,
    axes=(
        Axis("cos_theta", 0.0, 1.0, 2, "sqrt"),
        Axis("opd_nm", 0.0, MAX_OPD_NM, 2),
        Axis("eta3", 1.0, MAX_INDEX, 2),
        Axis("kappa3", 0.0, 10.0, 2, "sqrt"),
    ),
)


@dataclass
class SceneResult:
    """What ``bake_scene`` did: the folder, the files it wrote, the jobs it computed and reused (ids),
    whether the set was up to date, its wall seconds, what was not met and the device that ran."""

    out_dir: Path
    written: list[Path]
    computed: list[str]
    reused: list[str]
    up_to_date: bool
    seconds: float
    # material -> {de00_p99, de00_p99_bound}, where not met
    unmet: dict[str, dict[str, float]] = field(default_factory=dict)
    # one line per part the bake routed to the runtime table (a glTF source's: the material and why)
    routes: list[str] = field(default_factory=list)
    device: str | None = None  # the integrator's device, when a job was computed
    # a glTF bake's web set and build artefacts (lutbake/scene/shipping.py)
    ship: dict[str, Any] = field(default_factory=dict)


def scene_outputs(out: Path, scene: Scene, plan: ScenePlan, for_web: bool = False) -> dict[str, Path]:
    """Role -> path of every file of the scene's set (4D LUTs by job id); ``for_web``: the web set's roles only
    (lutbake/scene/shipping.py)."""
    paths = {
        role: out / f"{scene.stem}{suffix}"
        for role, suffix in (("manifest", ".json"), ("glsl", ".glsl"), ("hlsl", ".hlsl"))
    }
    if any(j.kind == "slice" for j in plan.jobs):
        paths["atlas"] = out / f"{scene.stem}.exr"
    for job in plan.jobs:
        if job.kind == "lut":
            paths.update({f"{job.id}{p.suffix}": p for p in lut_members(out / f"{job.id}.exr")})
    return {role: p for role, p in paths.items() if is_web_member(p.name, scene.stem)} if for_web else paths


def check_scene_outputs(out: Path, scene: Scene, plan: ScenePlan | None = None) -> None:
    """Refuse before any write: an output or the cache path taken by the wrong kind of entry, or an
    output that is one of the scene's own input files (inputs and outputs never alias)."""
    outputs = scene_outputs(out, scene, plan or plan_scene(scene))
    inputs = {Path(p).resolve(): p for p in (scene.path, *scene.inputs)}
    for path in outputs.values():
        if path.is_dir():
            raise ParameterError(
                "{out_dir} {out}: {path} is a folder, expected a file or nothing",
                out=repr(str(out)),
                path=repr(str(path)),
            )
        if path.resolve() in inputs:
            raise ParameterError(
                "{out_dir} {out}: the bake would overwrite its input {path}: choose another folder",
                out=repr(str(out)),
                path=repr(str(inputs[path.resolve()])),
            )
    cache = out / ".lutbake-cache"
    if cache.exists() and not cache.is_dir():
        raise ParameterError(
            "{out_dir} {out}: {path} is a file, expected the cache folder", out=repr(str(out)), path=repr(str(cache))
        )


def bake_scene(
    scene: Scene,
    out_dir: str | PathLike[str],
    force: bool = False,
    backend: str = "auto",
    progress: Progress = no_progress,
    device: str | None = None,
    for_web: bool = False,
) -> SceneResult:
    """Bake what ``scene`` needs into ``out_dir`` as one file set.

    Slices go into one atlas (NAME.exr, .json manifest, .glsl/.hlsl includes with the material table);
    each 4D job into its own LUT. Each job grows until its p99 ΔE00 at held-out points, measured on
    the stored values, meets the scene's ``max_de``. Unchanged jobs come from ``out_dir``'s cache; an
    unchanged scene writes nothing.

    Parameters
    ----------
    scene : Scene
        From ``load_scene`` (TOML) or ``load_gltf_scene`` (glTF).
    out_dir : str or os.PathLike
        Folder for the file set (created if absent).
    force : bool
        Recompute every job, ignoring the cache.
    backend : str
        'auto', 'opencl' or 'numpy' (see ``bake_lut``).
    progress : callable
        ``progress(done, total, note)`` before each job.
    device : str, optional
        OpenCL device (see ``bake_lut``).
    for_web : bool
        Write the web set alone (lutbake/scene/shipping.py): no HLSL includes, no LUT headers, no cache; the
        build artefacts an earlier bake of ``out_dir`` wrote (as its manifest names them) are removed.

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
    >>> soap = lutbake.FilmPoints.build(**atlas.film_stack("soap"), thickness_nm=300.0, cos_theta=[1.0, 0.5])
    >>> atlas.sample("soap", soap).shape
    (2, 3)
    """
    start = time.perf_counter()
    out = Path(out_dir)
    if out.suffix.lower() == ".exr":
        raise ParameterError("{out_dir} {out}: a scene bakes into a folder", out=repr(str(out_dir)))
    plan = plan_scene(scene)
    check_scene_outputs(out, scene, plan)
    scene_hash = _scene_hash(scene, plan)
    outputs = scene_outputs(out, scene, plan, for_web)
    earlier = earlier_build_artefacts(out, scene.stem) if for_web else []  # a full bake's, read before it goes
    with _new_folder(out), open_set(out, f"scene-{scene.stem}") as files:
        manifest = None if force else _up_to_date(outputs["manifest"], scene_hash, outputs, plan if for_web else None)
        if manifest is not None:
            reused, seconds = [j.id for j in plan.jobs], time.perf_counter() - start
            ship = _ship(manifest, scene, for_web)
            return SceneResult(out, [], [], reused, True, seconds, *_outcome(manifest), ship=ship)
        run = _JobRun(plan, None if for_web else SceneCache(out), force, backend, progress, device)
        entries, slices = run.all(out, files)
        routed = _choose_routes(scene, run, entries, slices, out, files)
        atlas = _write_atlas(files, outputs, scene, scene_hash, slices, entries)
        for name in routed:  # baked, but the runtime table serves it: no entry (the glTF source says why)
            del entries[name]
        if for_web:  # no LUT headers or HLSL, no LUT whose parts all went to the runtime table
            outputs = _served_outputs(outputs, plan, set(entries))
            for extra in set(files.members) - set(outputs.values()):
                files.members.pop(extra).unlink()
        manifest = _write_manifest(files, outputs, _manifest(scene, scene_hash, entries), atlas)
        written = sorted(files.members)
    removed = remove_build_artefacts(earlier, written)
    seconds = time.perf_counter() - start
    outcome = _outcome(manifest)
    ship = _ship(manifest, scene, for_web) | ({"removed": removed} if removed else {})
    return SceneResult(out, written, run.computed, run.reused, False, seconds, *outcome, run.device, ship)


def _scene_hash(scene: Scene, plan: ScenePlan) -> str:
    """What the set's bytes depend on: every job's hash, the materials in order and the source (a glTF's)."""
    return scene.hash_of(
        [job.hash for job in plan.jobs],
        [m.name for m in scene.materials],
        *([] if scene.source is None else [scene.source]),
    )


@contextlib.contextmanager
def _new_folder(out: Path) -> Iterator[None]:
    """``out`` (and its missing parents) for the block; the folders it created are removed again when the
    block fails and leaves them empty, so a refused bake (a device refused mid-way) leaves nothing behind."""
    created = [p for p in (out, *out.parents) if not p.exists()]  # deepest first
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ParameterError(
            "{out_dir} folder {out} cannot be created: {why}",
            out=repr(str(out)),
            why=exc.strerror or type(exc).__name__,
        ) from None
    try:
        yield
    except BaseException:
        for folder in created:
            with contextlib.suppress(OSError):  # not empty: completed slices stay cached
                folder.rmdir()
        raise


def _write_atlas(
    files: FileSet,
    outputs: dict[str, Path],
    scene: Scene,
    scene_hash: str,
    slices: list[SliceResult],
    entries: dict[str, dict[str, Any]],
) -> dict[str, Any]:
    """The slices packed into the atlas (lutbake/tables/atlas.py), written into the set where there are any,
    and each slice's materials' manifest entries added to ``entries``; the packed atlas."""
    atlas = pack_atlas([values for _, values, _ in slices])
    warn_texture_size(atlas["width"], atlas["height"], outputs["atlas"].name if slices else scene.stem)
    if slices:
        jobs, rects = [job for job, _, _ in slices], atlas["rects"]
        write_atlas(files.temp(outputs["atlas"]), atlas, atlas_header(scene, scene_hash, jobs, rects), scene.precision)
        for (job, _, record), rect in zip(slices, rects):
            entries.update(
                {name: slice_entry(job, record, rect, atlas, outputs["atlas"].name) for name in job.materials}
            )
    return atlas


def _write_manifest(
    files: FileSet, outputs: dict[str, Path], manifest: dict[str, Any], atlas: dict[str, Any]
) -> dict[str, Any]:
    """The includes, then the manifest listing every other member's SHA-256 and sealed with its own
    hash, written into the set; the manifest."""
    for lang, text in atlas_includes(manifest, atlas).items():
        if lang in outputs:  # the web set has no HLSL
            files.temp(outputs[lang]).write_text(text)
    manifest["files"] = {
        p.name: sha256_file(files.members.get(p, p)) for p in outputs.values() if p != outputs["manifest"]
    }
    # compact: engines read it; people read the receipts and `bake`'s lines (an indented manifest was 1.7x)
    files.temp(outputs["manifest"]).write_text(json.dumps(sealed(manifest), separators=(",", ":")) + "\n")
    return manifest


class _JobRun:
    """Every job of a plan, from the cache or computed (and then cached): slice values and 4D LUTs."""

    def __init__(
        self,
        plan: ScenePlan,
        cache: SceneCache | None,
        force: bool,
        backend: str,
        progress: Progress,
        device: str | None = None,
    ):
        self.plan, self.cache, self.force, self.backend, self.progress = plan, cache, force, backend, progress
        self.device_choice = device  # the OpenCL device asked for (``device`` below: the one that ran)
        self.computed: list[str] = []
        self.reused: list[str] = []
        self.integrator: Integrator | None = None

    @property
    def device(self) -> str | None:
        """The integrator's device, when a job was computed (it is made only then)."""
        return None if self.integrator is None else self.integrator.device

    def integrator_now(self) -> Integrator:
        """The integrator, made now if no job needed it."""
        return self._integrator()

    def _integrator(self) -> Integrator:
        if self.integrator is None:
            self.integrator = make_backend(self.backend, device=self.device_choice)
        return self.integrator

    def all(self, out: Path, files: FileSet) -> tuple[dict[str, dict[str, Any]], list[SliceResult]]:
        """(manifest entries of the 4D jobs' materials, [(job, values, record)] of the slices)."""
        entries: dict[str, dict[str, Any]] = {}
        slices: list[SliceResult] = []
        for done, job in enumerate(self.plan.jobs):
            self.progress(done, len(self.plan.jobs), f"{job.id} ({job.kind}: {', '.join(job.materials)})")
            if job.kind == "slice":
                slices.append((job, *self._slice(job)))
            else:
                record = self._lut(job, out, files)
                entries.update({name: _lut_entry(job, record) for name in job.materials})
        return entries, slices

    def _slice(self, job: SceneJob) -> tuple[np.ndarray, dict[str, Any]]:
        cached = None if self.force or self.cache is None else self.cache.slice(job)
        if cached is not None:
            self.reused.append(job.id)
            return cached
        values, record = refine_slice(job, self._integrator())
        self.computed.append(job.id)
        return values, record if self.cache is None else self.cache.store_slice(job, values, record)

    def _lut(self, job: SceneJob, out: Path, files: FileSet) -> dict[str, Any]:
        """The record of a ranged-base 4D LUT: reused when intact, else tuned and written."""
        path = out / f"{job.id}.exr"
        record = None if self.force or self.cache is None else self.cache.lut(job, path, lut_members(path))
        if record is not None:
            self.reused.append(job.id)
            return record
        record = tuned_lut(job, path, self.backend, files, self._integrator(), self.device_choice)
        if self.cache is not None:
            self.cache.store_lut(job, record)
        self.computed.append(job.id)
        return record


def _lut_entry(job: SceneJob, record: dict[str, Any]) -> dict[str, Any]:
    return {
        "kind": "lut",
        "job": job.id,
        "file": f"{job.id}.exr",
        "counts": record["counts"],
        **{k: record[k] for k in ERROR_KEYS},
        **{k: record[k] for k in ("path_scoring",) if k in record},
        "sample": "lutbake_sample (docs/lut-format.md)",
    }


def _manifest(scene: Scene, scene_hash: str, entries: dict[str, dict[str, Any]]) -> dict[str, Any]:
    manifest = {
        "format": MANIFEST_FORMAT[0],
        "format_version": MANIFEST_FORMAT[1],
        "scene": scene.file_name,
        "scene_hash": scene_hash,
        "settings": scene.settings_key(),
        "materials": {m.name: entries[m.name] for m in scene.materials if m.name in entries},
    }
    if scene.source is not None:  # each texture-driven metal's table written once (io/manifest.py)
        manifest["source"], tables = shared_metal_tables(scene.source)
        manifest |= {"metal_tables": tables} if tables else {}
    return manifest


def _served_outputs(outputs: dict[str, Path], plan: ScenePlan, served: set[str]) -> dict[str, Path]:
    """``outputs`` less the files of the 4D jobs none of whose materials the set serves (routed elsewhere)."""
    unserved = {f"{job.id}." for job in plan.jobs if job.kind == "lut" and not served & set(job.materials)}
    return {role: p for role, p in outputs.items() if not any(p.name.startswith(u) for u in unserved)}


def _up_to_date(
    manifest_path: Path, scene_hash: str, outputs: dict[str, Path], web_plan: ScenePlan | None = None
) -> dict[str, Any] | None:
    """The manifest when the set is up to date — unedited (its own hash holds), this scene's, every member
    it lists present with the recorded hash —; else None. ``web_plan``: a web set's, whose LUTs serving no
    material are not written."""
    try:
        manifest = read_scene_manifest(manifest_path)  # typed, and its seal holds
        if web_plan is not None:
            outputs = _served_outputs(outputs, web_plan, set(manifest["materials"]))
        files = manifest["files"]
        if manifest["scene_hash"] != scene_hash or sorted(files) != sorted(
            p.name for p in outputs.values() if p != manifest_path
        ):
            return None
        fresh = all(sha256_file(manifest_path.parent / name) == digest for name, digest in files.items())
        return manifest if fresh else None
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return None


def _outcome(manifest: dict[str, Any]) -> tuple[dict[str, dict[str, float]], list[str]]:
    """(what the set's materials and parts did not meet on the route that serves them: their p99 ΔE00 and the
    bound held; the lines of the parts routed to the runtime table)."""
    unmet = {
        name: {"de00_p99": e["de00_p99"], "de00_p99_bound": e["de00_p99_bound"]}
        for name, e in manifest["materials"].items()
        if not e["target_met"]
    }
    source = manifest.get("source")
    return unmet | source_unmet(source), route_lines(source)


def _ship(manifest: dict[str, Any], scene: Scene, for_web: bool) -> dict[str, Any]:
    """A glTF bake's web set and build artefacts (nothing for other scenes)."""
    if scene.source is None or scene.source.get("kind") != "gltf":
        return {}
    return shipping(manifest, scene.stem, cache=not for_web)


def _choose_routes(
    scene: Scene,
    run: _JobRun,
    entries: dict[str, dict[str, Any]],
    slices: list[SliceResult],
    out: Path,
    files: FileSet,
) -> set[str]:
    """A glTF scene's routes (lutbake/scene/gltf/routes.py), its parts scored on the tables as the engine will
    read them: each slice as the atlas stores it, each LUT as written; the scene materials the runtime table
    serves instead. Nothing for other scenes (no runtime route)."""
    if scene.source is None or scene.source.get("kind") != "gltf":
        return set()
    atlases = {name: slice_atlas(job, values) for job, values, _ in slices for name in job.materials}
    met = {name: bool(r["target_met"]) for job, _, r in slices for name in job.materials}
    met |= {name: bool(e["target_met"]) for name, e in entries.items()}
    luts: dict[str, Lut] = {}

    def sampler_of(name: str) -> Sampler:
        if name in atlases:
            return functools.partial(atlases[name].sample, "slice")
        path = out / entries[name]["file"]
        return luts.setdefault(name, Lut.load(files.members.get(path, path))).sample

    def truth_of(eta2: float) -> Sampler:  # the integrator is made only where a part is checked
        spec = replace(_TRUTH_SPEC, eta2=eta2, eta1=scene.eta1, observer=scene.observer, space=scene.space)
        return functools.partial(run.integrator_now().evaluate, spec)

    def rerefine(names: list[str], factor: float) -> set[str]:  # the slices serving ``names``, refined in place
        changed: set[str] = set()
        for i, (job, _, record) in enumerate(slices):
            if set(job.materials) & set(names):
                target = record["de00_p99_bound"] * factor
                values, again = refine_slice(job, run.integrator_now(), target, tuple(record["counts"]))
                slices[i] = (job, values, {**again, "rerefined_to": target})
                atlases.update({name: slice_atlas(job, values) for name in job.materials})
                changed.update(job.materials)
        return changed

    return choose_routes(scene, met.__getitem__, sampler_of, truth_of, rerefine)
