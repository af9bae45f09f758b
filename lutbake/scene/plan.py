"""The plan of a scene: the jobs that serve its materials (docs/scene.md, What gets baked).

Materials with a fixed base (constant or a named dispersive material) need only a 2D slice over
(cos θ, film thickness), one thickness row when the thickness is fixed; materials that share film,
thickness range and base share a slice. Only a base given as η3/κ3 ranges (texture-driven) needs a
4D LUT, over just those ranges. Every job's optical path is checked here, before anything is
written, and a failure names the material's field in its source. Running the jobs is
lutbake/scene/jobs.py's; packing and writing them, lutbake/scene/bake.py's.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.physics.materials import material
from lutbake.physics.points import MAX_OPD_NM, FilmPoints
from lutbake.quality.measure import RESCORED
from lutbake.quality.refine import TUNE_START_COUNTS
from lutbake.scene.model import Scene, SceneMaterial
from lutbake.scene.slices import SliceStack

__all__ = ["SceneJob", "ScenePlan", "plan_scene", "truth_rate", "MAX_SLICE_COUNT", "SCORED_POINTS", "SCORING"]

MAX_SLICE_COUNT = 256  # per slice axis: 256 × 256 texels, 384 KiB in half
# Points a job's trials are scored at (lutbake/scene/jobs.py), colour by the bake's integrator: a slice's uniform
# points (beside every centre of its cells), a 4D job's `report` points (half uniform, half cell centres;
# along a base path, this many of each kind). The bound held at them is what a 1,000-point `report` needs.
SCORED_POINTS = {"slice": 1000, "lut": 1000}
# What a job is refined to: part of its content hash, so a cache entry refined by another rule is recomputed.
SCORING = (
    "report p99 at 99 % of seeds: bound_level of report's population; along a base path the "
    "single-base bound and the per-channel p99"
)
_VISIBLE_NM = np.linspace(360.0, 830.0, 95)
# truth_rate samples at most this many jobs: a plan of 10^5 materials is timed in a fraction of a second.
_RATE_JOBS = 8


@dataclass
class SceneJob:
    """A 2D (cos θ, thickness) slice or a 4D LUT serving one or more materials."""

    kind: str  # "slice" or "lut"
    key: dict[str, Any]
    materials: list[str]
    scene: Scene = field(repr=False)
    counts: tuple[int, ...] = ()

    @cached_property
    def hash(self) -> str:
        return self.scene.hash_of(self.kind, self.key, SCORING)

    @property
    def id(self) -> str:
        return f"{self.kind}-{self.hash[:12]}"

    @property
    def thickness_nm(self) -> tuple[float, float]:
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

    def film_index_max(self) -> float:
        """The film's largest index over the visible (what bounds its optical path)."""
        film = self.key["film"]
        return float(np.max(material(film).index(_VISIBLE_NM)[0])) if isinstance(film, str) else float(film)

    def bytes_estimate(self, counts: tuple[int, ...] | None = None) -> int:
        per_texel = 6 if self.scene.precision == "half" else 12
        return int(np.prod(counts or self.counts)) * per_texel

    def lut_spec(self) -> BakeSpec:
        """A ranged-base job's 4D domain (a fixed thickness is widened to a 2-node D axis)."""
        eta2 = float(self.key["film"])
        d_lo, d_hi = _widen(*(2 * eta2 * t for t in self.thickness_nm))
        (e_lo, e_hi), (k_lo, k_hi) = (_widen(*r) for r in self.key["base"])
        axes = (
            Axis("cos_theta", 0.0, 1.0, 32, "sqrt"),
            Axis("opd_nm", d_lo, d_hi, 128),
            Axis("eta3", e_lo, e_hi, 16),
            Axis("kappa3", k_lo, k_hi, 16, "sqrt"),
        )
        s = self.scene
        return BakeSpec(eta2=eta2, eta1=s.eta1, axes=axes, space=s.space, observer=s.observer, precision=s.precision)


def _widen(lo: float, hi: float) -> tuple[float, float]:
    return (lo, hi) if hi > lo else (lo, lo + 1e-6 * max(1.0, abs(lo)))


@dataclass
class ScenePlan:
    """A scene and the jobs that serve its materials, in material order (``plan_scene``)."""

    scene: Scene
    jobs: list[SceneJob]

    def describe(self, seconds_per_truth_point: float | None = None) -> dict[str, Any]:
        """Jobs, axes, starting counts and bytes (slices grow until their target holds); with a
        measured ``seconds_per_truth_point`` (``truth_rate``), each job's ground-truth seconds."""
        rows = []
        for job in self.jobs:
            row: dict[str, Any] = {
                "id": job.id,
                "kind": job.kind,
                "materials": job.materials,
                "counts": list(job.counts),
                "bytes_start": job.bytes_estimate(),
            }
            if job.kind == "slice":
                row["axes"] = {"cos_theta": [0.0, 1.0, "sqrt"], "thickness_nm": job.key["thickness_nm"]}
                row["bytes_max"] = job.bytes_estimate((MAX_SLICE_COUNT, 1 if job.fixed_thickness else MAX_SLICE_COUNT))
            else:
                row["axes"] = [{k: v for k, v in a.describe().items() if k != "count"} for a in job.lut_spec().axes]
            if seconds_per_truth_point is not None:
                row["truth_seconds_estimate"] = seconds_per_truth_point * _truth_points(job)
            rows.append(row)
        from lutbake.lut.bake import default_specs

        generic = next(iter(default_specs().values())).cells * (6 if self.scene.precision == "half" else 12)
        return {
            "scene": self.scene.file_name,
            "settings": self.scene.settings_key(),
            "jobs": rows,
            "bytes_start_total": sum(r["bytes_start"] for r in rows),
            "generic_4d_bytes": generic,
        }


def _initial_counts(job: SceneJob) -> tuple[int, ...]:
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
    jobs: dict[str, SceneJob] = {}
    for m in scene.materials:
        kind = "lut" if m.base_is_range else "slice"
        key = m.slice_key()
        ident = json.dumps([kind, key], sort_keys=True)
        if ident not in jobs:
            jobs[ident] = SceneJob(kind, key, [], scene)
            _check_optical_path(jobs[ident], m)
        jobs[ident].materials.append(m.name)
    out = list(jobs.values())
    for job in out:
        job.counts = _initial_counts(job)
    return ScenePlan(scene, out)


def _check_optical_path(job: SceneJob, m: SceneMaterial) -> None:
    """Refuse a job whose optical path D = 2·η2·d passes MAX_OPD_NM (η2 at its largest over the
    visible for a named film), naming the material's thickness where its source gave it."""
    eta2 = job.film_index_max()
    opd = 2.0 * eta2 * job.thickness_nm[1]
    if opd > MAX_OPD_NM:
        raise ValueError(
            f"{m.where('thickness_nm')}: the optical path 2·η2·d reaches {opd:g} nm (η2 {eta2:g}, d "
            f"{job.thickness_nm[1]:g} nm): at most {MAX_OPD_NM:g} nm is allowed, so d <= "
            f"{MAX_OPD_NM / (2.0 * eta2):g} nm for this film"
        )


def _truth_points(job: SceneJob) -> int:
    """Ground-truth points a job's bake evaluates (lutbake/spectral/reference.py): the searched max's local
    maxima and worst scored point (measure.search_stacks), and a 4D job tuned over its domain also its report
    points."""
    rescored = RESCORED + 1
    return rescored if job.kind == "slice" or "base_path" in job.key else SCORED_POINTS["lut"] + RESCORED


def truth_rate(plan: ScenePlan, points: int = 16) -> float:
    """Seconds per ground-truth point, measured now on this machine at ``points`` points in the
    domains of up to 8 of the plan's jobs (colour tables are built by an untimed warm-up first)."""
    from lutbake.spectral.reference import reference_colour

    rng = np.random.default_rng(0)

    def sample(job: SceneJob, n: int) -> None:
        cos_t, d = rng.uniform(0.0, 1.0, n) ** 2, rng.uniform(*job.thickness_nm, n)
        if job.kind == "slice":
            pts = job.stack().points(cos_t, d)
        else:
            (e_lo, e_hi), (k_lo, k_hi) = job.key["base"]
            pts = FilmPoints.build(
                eta1=job.scene.eta1,
                eta2=float(job.key["film"]),
                cos_theta=cos_t,
                thickness_nm=d,
                eta3=rng.uniform(e_lo, e_hi, n),
                kappa3=rng.uniform(k_lo, k_hi, n),
            )
        reference_colour(pts, job.scene.observer, job.scene.space)

    jobs = plan.jobs[:: max(1, -(-len(plan.jobs) // _RATE_JOBS))]  # spread over the plan
    for job in jobs:
        sample(job, 2)
    start = time.perf_counter()
    for job in jobs:
        sample(job, points)
    return (time.perf_counter() - start) / (points * max(len(jobs), 1))
