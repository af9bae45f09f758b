"""How long a scene bake will take on this machine: `plan`'s estimate, measured now rather than modelled
(issue 34 item 5; bench/bench_gltf_plan.py holds it against the bake, docs/gltf.md gives the table).

A bake's time is its integrator's start-up, its slice jobs (each refined until its target holds, then its max
searched), its 4D jobs (refined, then their max searched over ``LUT_SEARCH_BUDGET`` evaluations) and a glTF
scene's composed-colour checks (lutbake/scene/gltf/routes.py). Measured now: the start-up (making the
integrator), up to ``SAMPLED_SLICES`` of the plan's slice jobs refined for real (spread over the plan; their
mean times the count), and one 4D job read along a base path (a texture-driven glTF metal) run for real as
the bake runs it (jobs.refine_path: its points, every trial of its refinement; then its searched max), times
the count of such jobs. A 4D job over a whole base box (a TOML scene's ranged base) is counted as the
direct rule's seconds per point times the points it evaluates, at ``LUT_COST_PER_POINT`` of that rate. The
composed checks: their points at the direct rule's rate. Nothing is written.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.lut.sample import Lut
from lutbake.physics.points import FilmPoints
from lutbake.quality.refine import REPORT_POINTS
from lutbake.scene.gltf.routes import composed_parts
from lutbake.scene.jobs import LUT_SEARCH_BUDGET, refine_path, refine_slice
from lutbake.scene.plan import SceneJob
from lutbake.spectral.reference import subset

if TYPE_CHECKING:
    from lutbake.scene.plan import ScenePlan
    from lutbake.scene.slices import Integrator

__all__ = ["time_estimate", "SAMPLED_SLICES", "LUT_COST_PER_POINT"]

SAMPLED_SLICES = 3
# A box 4D job's seconds per point of its search budget and scored points, in units of the direct rule's seconds
# per uniform point of its domain (TOML scenes' ranged bases; glTF's 4D jobs are path jobs, measured instead).
LUT_COST_PER_POINT = 6.0
_RATE_POINTS = 500


def time_estimate(plan: ScenePlan, integrator: Integrator, startup_s: float) -> dict[str, Any]:
    """Seconds a bake of ``plan`` will take here, by stage ({startup_s, slices_s, luts_s, checks_s,
    estimate_seconds, sampled_slice_jobs, sampled_lut_jobs})."""
    slices = [job for job in plan.jobs if job.kind == "slice"]
    sampled = slices[:: max(1, -(-len(slices) // SAMPLED_SLICES))][:SAMPLED_SLICES]
    per_slice = float(np.mean([_timed_slice(job, integrator) for job in sampled])) if sampled else 0.0
    paths = [job for job in plan.jobs if job.kind == "lut" and "base_path" in job.key]
    boxes = sum(job.kind == "lut" and "base_path" not in job.key for job in plan.jobs)
    checks = len(composed_parts(plan.scene.source)) if plan.scene.source else 0
    per_point = _check_rate(plan, integrator) if boxes or checks else 0.0
    box_points = LUT_COST_PER_POINT * (LUT_SEARCH_BUDGET + 4 * REPORT_POINTS)  # 4: single-base and 3 channels
    stages = {
        "startup_s": startup_s,
        "slices_s": per_slice * len(slices),
        "luts_s": len(paths) * (_timed_path_job(paths[0], integrator) if paths else 0.0)
        + boxes * box_points * per_point,
        "checks_s": checks * 3 * REPORT_POINTS * per_point,
    }
    return {
        **stages,
        "estimate_seconds": sum(stages.values()),
        "sampled_slice_jobs": [j.id for j in sampled],
        "sampled_lut_jobs": [j.id for j in paths[:1]],
    }


def _timed_path_job(job: SceneJob, integrator: Integrator) -> float:
    """Seconds of a path job run now as the bake runs it: its refinement and its searched max (whose cost is
    where it climbs: grazing angles and long paths, where the direct rule is dearest; a compass step of its
    starts timed alone was 3-5x short), and its final grid baked once more (the winning trial's seconds: the
    file the bake writes)."""
    start = time.perf_counter()
    points, result = refine_path(job, integrator)
    assert isinstance(result.artefact, Lut)  # what the path refinement builds
    points.searched(result.artefact, integrator)
    return time.perf_counter() - start + result.best.seconds


def _timed_slice(job: SceneJob, integrator: Integrator) -> float:
    start = time.perf_counter()
    refine_slice(job, integrator)
    return time.perf_counter() - start


def _direct_rate(job: SceneJob, integrator: Integrator) -> float:
    """Seconds per point of the bake's direct rule (integrator.evaluate) over a 4D job's domain."""
    spec = job.lut_spec()
    rng = np.random.default_rng(0)
    cos_axis, opd_axis, eta3_axis, kappa3_axis = spec.axes
    points = FilmPoints.build(
        eta1=spec.eta1,
        eta2=spec.eta2,
        cos_theta=rng.uniform(0.0, 1.0, _RATE_POINTS) ** 2,
        opd_nm=rng.uniform(opd_axis.lo, opd_axis.hi, _RATE_POINTS),
        eta3=rng.uniform(eta3_axis.lo, eta3_axis.hi, _RATE_POINTS),
        kappa3=rng.uniform(kappa3_axis.lo, kappa3_axis.hi, _RATE_POINTS),
    )
    integrator.evaluate(spec, subset(points, np.arange(8)))  # the first call builds the kernel's arguments
    start = time.perf_counter()
    integrator.evaluate(spec, points)
    return (time.perf_counter() - start) / _RATE_POINTS


def _check_rate(plan: ScenePlan, integrator: Integrator) -> float:
    """Seconds per point of the direct rule at a composed check's points: a 4D job's rate where the plan has one,
    else a film of index 1.4 over a dielectric of 1.2-1.8, 100-400 nm thick."""
    luts = [job for job in plan.jobs if job.kind == "lut"]
    if luts:
        return _direct_rate(luts[0], integrator)
    key = {"film": 1.4, "thickness_nm": [100.0, 400.0], "base": [[1.2, 1.8], [0.0, 0.0]]}
    film = SceneJob("lut", key, [], plan.scene)
    return _direct_rate(film, integrator)
