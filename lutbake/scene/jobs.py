"""Running a scene's jobs: each slice integrated (lutbake/scene/slices.py) and grown by the refinement engine
(lutbake/quality/refine.py) until what `lutbake report` will measure meets the scene's target at any seed; each
ranged-base job tuned and baked as a 4D LUT.

A target holds on `report`'s statistic, not on one sample of it. `report ATLAS` scores a slice at
1,000 points, half uniform in (√cos θ, thickness) and half at centres of random cells of its grid,
and takes their p99. A trial slice is scored on the same population: every one of its cells' centres
(so that half is exact, not sampled) and a fixed sample of uniform points, as the atlas stores it
(rounded to half or float, sampled by the atlas sampler, sample.Atlas), against the slice's own
integrator (slices.slice_colour: ≤ 1e-5 from the ground truth in RGB, tested; far cheaper than
lutbake/spectral/reference.py where films are thick). Refinement holds the mixture's ``refine.bound_level`` percentile
(99.73) to the target: the p99 of a fresh 1,000-point report then stays below it at 99 % of seeds.
The finished slice's max is searched (measure.search_slice) and its local maxima scored against the
independent ground truth (lutbake/spectral/reference.py). A 4D job is tuned by ``refine.tune`` the same way (report's
points for its grid, the same bound), or, read only along a base path, scored where the engine reads
it (``_path_measure``: single-base points held to the bound, per-channel ones to their p99). What a job
yields: its values (slices) or its LUT's record, and the record the cache and the manifest keep (counts,
p99, the bound held, the searched max).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.grid.spec import BakeSpec
from lutbake.integrate.batch import fast_colours
from lutbake.io.fileset import FileSet, sha256_file
from lutbake.lut.bake import write_lut
from lutbake.lut.sample import Atlas, Lut
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.materials import material
from lutbake.physics.points import FilmPoints
from lutbake.quality.measure import SLICE_SEARCH_BUDGET, search_slice, search_stacks
from lutbake.quality.refine import (
    REPORT_POINTS,
    Refinement,
    Trial,
    bound_level,
    mixture_percentile,
    p99_bound,
    refine,
    trial_lut,
    tune,
)
from lutbake.quality.worstcase import SearchAxis
from lutbake.scene.plan import MAX_SLICE_COUNT, SCORED_POINTS, SceneJob
from lutbake.scene.slices import SliceStack, integrate_slice, slice_colour, slice_grid
from lutbake.tables.atlas import slice_header

if TYPE_CHECKING:
    from lutbake.scene.slices import Integrator

    # A slice's fixed uniform points and their colour by its integrator (``uniform_points``).
    Uniform = tuple[FilmPoints, np.ndarray]

__all__ = ["uniform_points", "refine_slice", "slice_atlas", "tuned_lut", "refine_path", "LUT_SEARCH_BUDGET"]

_LUT_MAX_ROUNDS = 6
_SEARCH_STARTS = 100  # the worst scored points of each kind a searched max starts from (with the box's own)
LUT_SEARCH_BUDGET = 20000  # a 4D job's searched max (tune's, as `report`'s)


def uniform_points(job: SceneJob, stack: SliceStack, integrator: Integrator, seed: int = 0) -> Uniform:
    """(film stacks, RGB) at the slice's fixed uniform points in (√cos θ, thickness), their colour by
    the slice's integrator (slices.slice_colour)."""
    rng = np.random.default_rng(seed)
    n, s = SCORED_POINTS["slice"], job.scene
    pts = stack.points(rng.uniform(0.0, 1.0, n) ** 2, rng.uniform(*job.thickness_nm, n))
    return pts, slice_colour(stack, pts, job.thickness_nm, integrator, s.observer, s.space)


@dataclass
class _ScoredSlice:
    """A trial slice: its values (float64), the atlas it is stored as, and ΔE00 at its scored points."""

    values: np.ndarray
    atlas: Atlas
    de00_uniform: np.ndarray
    de00_centres: np.ndarray
    # (cos θ, thickness) of every cell centre, in the order of de00_centres
    centres: tuple[np.ndarray, np.ndarray]


def _slice_measure(
    job: SceneJob, stack: SliceStack, uniform: Uniform, integrator: Integrator
) -> Callable[[tuple[int, ...], str], tuple[Trial, _ScoredSlice]]:
    """``refine``'s measure for a slice: integrated, stored, scored at the uniform points and at every cell
    centre (their colour from the grid of centres, slices.integrate_slice), held to the bound."""
    pts, truth = uniform
    s = job.scene

    def measure(counts: tuple[int, ...], label: str) -> tuple[Trial, _ScoredSlice]:
        values = integrate_slice(stack, counts, job.thickness_nm, integrator, s.observer, s.space)
        atlas = slice_atlas(job, values)
        cos_c, d_c = (g.ravel() for g in np.meshgrid(*slice_grid(counts, job.thickness_nm, centres=True)))
        centre_truth = integrate_slice(stack, counts, job.thickness_nm, integrator, s.observer, s.space, centres=True)
        de_u = delta_e00(atlas.sample("slice", pts), truth, s.observer, s.space)
        de_c = delta_e00(
            atlas.sample("slice", stack.points(cos_c, d_c)), centre_truth.reshape(-1, 3), s.observer, s.space
        )
        p99 = mixture_percentile([de_u, de_c], 99.0)
        bound = mixture_percentile([de_u, de_c], bound_level(REPORT_POINTS))
        scored = _ScoredSlice(values, atlas, de_u, de_c, (cos_c, d_c))
        return Trial(counts, p99, atlas.image.nbytes, 0.0, gated=bound), scored

    return measure


def slice_atlas(job: SceneJob, values: np.ndarray) -> Atlas:
    """A slice's values (rows, columns, 3) as the atlas stores them (rounded to the scene's precision), alone
    in an atlas whose one material is 'slice': what the engine samples, without the packing."""
    s, (rows, columns) = job.scene, values.shape[:2]
    header = {**slice_header(job, [0, 0, columns, rows]), "materials": ["slice"]}
    stored = np.float16 if s.precision == "half" else np.float32
    return Atlas({"eta1": s.eta1, "space": s.space, "observer": s.observer, "slices": [header]}, values.astype(stored))


def refine_slice(
    job: SceneJob, integrator: Integrator, target: float | None = None, start: tuple[int, ...] | None = None
) -> tuple[np.ndarray, dict[str, Any]]:
    """The slice grown from ``start`` (the job's counts) until its stored values meet ``target`` (the scene's)
    on `report`'s statistic at any seed, then its max searched: (values (rows, columns, 3) in float64,
    record; ``target_met`` is against the scene's target)."""
    s = job.scene
    stack = job.stack()  # one stack: it keeps what it learns about its materials' spectra
    uniform = uniform_points(job, stack, integrator)
    frozen = (1,) if job.fixed_thickness else ()
    measure = _slice_measure(job, stack, uniform, integrator)
    result = refine(measure, start or job.counts, target or s.max_de, frozen=frozen, cap=MAX_SLICE_COUNT)
    best = result.artefact
    assert isinstance(best, _ScoredSlice)  # what _slice_measure builds
    worst = _searched_slice(job, stack, uniform, best, integrator)
    record = {
        "counts": list(result.counts),
        "de00_p99": result.best.de00_p99,
        "de00_p99_bound": result.best.held,
        "target_met": result.best.held <= s.max_de,
        "de00_max": worst["de00_max"],
        "worst_case": worst,
        "scored_points": {"uniform": len(best.de00_uniform), "cell_centres": len(best.de00_centres)},
        "constant_index_de00_p99": _constant_index_error(job, uniform, integrator),
    }
    return best.values, record


def _searched_slice(
    job: SceneJob, stack: SliceStack, uniform: Uniform, best: _ScoredSlice, integrator: Integrator
) -> dict[str, Any]:
    """The finished slice's searched max (measure.search_slice), climbed against its integrator from the
    worst scored points of each kind, its local maxima scored against the ground truth."""
    s = job.scene
    worst_u = np.argsort(-best.de00_uniform)[:_SEARCH_STARTS]
    worst_c = np.argsort(-best.de00_centres)[:_SEARCH_STARTS]
    cos_t = np.concatenate([uniform[0].cos_theta[worst_u], best.centres[0][worst_c]])
    thickness = np.concatenate([uniform[0].thickness_nm[worst_u], best.centres[1][worst_c]])
    de = np.concatenate([best.de00_uniform[worst_u], best.de00_centres[worst_c]])

    def proxy(points: FilmPoints) -> np.ndarray:
        return slice_colour(stack, points, job.thickness_nm, integrator, s.observer, s.space)

    header = best.atlas.meta["slices"][0]
    return search_slice(best.atlas, header, cos_t, thickness, de, SLICE_SEARCH_BUDGET, 0, proxy)


def _constant_index_error(job: SceneJob, uniform: Uniform, integrator: Integrator) -> float | None:
    """p99 ΔE00 if the slice's named materials were taken at their 550 nm index (what a constant-index
    LUT would show), at the uniform points; None without named materials."""
    film, base = job.key["film"], job.key["base"]
    if not isinstance(film, str) and not isinstance(base, str):
        return None
    pts, truth = uniform
    eta3, kappa3 = (float(v) for v in material(base).index(550.0)) if isinstance(base, str) else base
    approx_pts = FilmPoints.build(
        eta1=job.scene.eta1,
        eta2=job.film_index_550(),
        cos_theta=pts.cos_theta,
        thickness_nm=pts.thickness_nm,
        eta3=eta3,
        kappa3=kappa3,
    )
    approx = fast_colours(approx_pts, job.scene.observer, job.scene.space, integrator)[0]  # the kernel
    return float(np.percentile(delta_e00(approx, truth, job.scene.observer, job.scene.space), 99))


def tuned_lut(
    job: SceneJob, path: Path, backend: str, files: FileSet, integrator: Integrator, device: str | None = None
) -> dict[str, Any]:
    """Bake the 4D LUT at the smallest counts whose bound meets the target into ``files``: scored at
    `report`'s points of its domain (refine.tune), or along its ``base_path`` where the engine reads it
    only there (``_path_measure``, by ``integrator``); its record (counts, p99, the bound, whether the
    target was met, the searched max, along a path each kind's p99 and bound, the EXR's SHA-256)."""
    spec = job.lut_spec()
    frozen = (1,) if job.fixed_thickness else ()
    if "base_path" in job.key:
        points, result = refine_path(job, integrator)
        assert isinstance(result.artefact, Lut)  # what _path_measure builds
        worst = points.searched(result.artefact, integrator)
    else:
        result = tune(
            spec,
            job.scene.max_de,
            n_points=SCORED_POINTS["lut"],
            seed=0,
            backend=backend,
            max_rounds=_LUT_MAX_ROUNDS,
            start=job.counts,
            frozen=frozen,
            search_budget=LUT_SEARCH_BUDGET,
            device=device,
        )
        worst = result.best.stats["worst_case"]
    axes = tuple(a.resized(c) for a, c in zip(spec.axes, result.counts))
    write_lut(replace(spec, axes=axes), path, files, backend, device=device)
    scoring = {"path_scoring": result.best.stats} if "base_path" in job.key else {}
    return {
        "counts": list(result.counts),
        "de00_p99": result.best.de00_p99,
        "de00_p99_bound": result.best.held,
        "target_met": result.met,
        "de00_max": worst["de00_max"],
        "worst_case": {
            k: worst[k]
            for k in (
                "de00_max",
                "cos_theta",
                "opd_nm",
                "eta3",
                "kappa3",
                "found_by",
                "held_out_max",
                "evaluations",
                "budget",
            )
        },
        **scoring,
        "sha256": sha256_file(files.members[path]),
    }


def refine_path(job: SceneJob, integrator: Integrator) -> tuple[_PathPoints, Refinement]:
    """A 4D job read along its ``base_path``: its scored points and its refinement to the smallest counts
    that meet the target there (the Lut is the result's artefact); its search is left to the caller."""
    spec = job.lut_spec()
    points = _PathPoints.build(spec, job.key["base_path"], integrator)
    frozen = (1,) if job.fixed_thickness else ()
    measure = _path_measure(spec, points, integrator)
    return points, refine(measure, job.counts, job.scene.max_de, frozen=frozen, max_rounds=_LUT_MAX_ROUNDS)


@dataclass
class _PathPoints:
    """Where the engine reads a 4D LUT along a base path (a texture-driven glTF metal: docs/gltf.md), in
    two kinds, their colour by the bake's direct rule: ``single`` stacks, one base for every channel (a
    grey texel: F0 uniform along the whole path), and ``channels``, one stack per channel, channel c's
    base uniform along the fraction of the path its F0 reaches (what the receipt scores: channel c of
    the colour is channel c of its own stack's)."""

    spec: BakeSpec
    path: dict[str, Any]
    single: FilmPoints
    single_at: np.ndarray  # the single stacks' positions along the path (node units)
    channels: list[FilmPoints]
    truth_single: np.ndarray
    truth_channels: np.ndarray

    @classmethod
    def build(
        cls, spec: BakeSpec, path: dict[str, Any], integrator: Integrator, n: int = REPORT_POINTS, seed: int = 0
    ) -> _PathPoints:
        rng = np.random.default_rng(seed)
        cos_t, opd = rng.uniform(0.0, 1.0, n) ** 2, rng.uniform(spec.axes[1].lo, spec.axes[1].hi, n)
        top = len(path["eta3"]) - 1.0

        def along(at: np.ndarray) -> FilmPoints:
            return _path_stack(spec, path, cos_t, opd, at)

        single_at = rng.uniform(0.0, top * max(path["channel_reach"]), n)
        single, channels = (
            along(single_at),
            [along(rng.uniform(0.0, top * reach, n)) for reach in path["channel_reach"]],
        )
        truth = lambda stack: integrator.evaluate(spec, stack)  # noqa: E731 - the bake's direct rule
        return cls(spec, path, single, single_at, channels, truth(single), _composed(truth, channels))

    def errors(self, lut: Lut) -> tuple[np.ndarray, np.ndarray]:
        """ΔE00 of ``lut`` at the single-base points and at the per-channel composed points."""
        space, observer = self.spec.space, self.spec.observer
        return (
            delta_e00(lut.sample(self.single), self.truth_single, observer, space),
            delta_e00(_composed(lut.sample, self.channels), self.truth_channels, observer, space),
        )

    def searched(self, lut: Lut, integrator: Integrator) -> dict[str, Any]:
        """The max along the path (one base for every channel) over (√cos θ, D, position along the path),
        climbed against the bake's direct rule from the worst single-base points, its local maxima scored
        against the ground truth (measure.search_stacks)."""
        de, _ = self.errors(lut)
        cos_axis, opd_axis = self.spec.axes[:2]
        top = len(self.path["eta3"]) - 1.0

        def stack_at(unit: np.ndarray) -> FilmPoints:
            return _path_stack(
                self.spec,
                self.path,
                np.asarray(cos_axis.from_unit(unit[:, 0])),
                np.asarray(opd_axis.from_unit(unit[:, 1])),
                unit[:, 2] * top,
            )

        starts = np.argsort(-de)[:_SEARCH_STARTS]
        at = np.column_stack(
            [cos_axis.to_unit(self.single.cos_theta), opd_axis.to_unit(self.single.opd_nm), self.single_at / top]
        )[starts]
        axes = (
            SearchAxis("cos_theta", cells=cos_axis.count - 1),
            SearchAxis("opd_nm", cells=opd_axis.count - 1),
            SearchAxis("base_path", cells=int(top)),
        )
        places = {"cos θ → 0": {"cos_theta": 0.0}} | ({"D → 0": {"opd_nm": 0.0}} if opd_axis.lo == 0.0 else {})
        found = search_stacks(
            stack_at,
            lut.sample,
            axes,
            at,
            de[starts],
            places,
            LUT_SEARCH_BUDGET,
            0,
            self.spec.space,
            self.spec.observer,
            lambda stack: integrator.evaluate(self.spec, stack),
        )
        stack = found.pop("at")
        return {
            "de00_max": found.pop("de00_max"),
            **{k: float(getattr(stack, k)[0]) for k in ("cos_theta", "opd_nm", "eta3", "kappa3")},
            **found,
        }


def _path_stack(
    spec: BakeSpec, path: dict[str, Any], cos_theta: np.ndarray, opd_nm: np.ndarray, at: np.ndarray
) -> FilmPoints:
    """Film stacks of ``spec``'s film whose base lies at position ``at`` (node units) along ``path``."""
    nodes = np.arange(len(path["eta3"]))
    return FilmPoints.build(
        eta1=spec.eta1,
        eta2=spec.eta2,
        cos_theta=cos_theta,
        opd_nm=opd_nm,
        eta3=np.interp(at, nodes, path["eta3"]),
        kappa3=np.interp(at, nodes, path["kappa3"]),
    )


def _composed(colour: Callable[[FilmPoints], np.ndarray], stacks: list[FilmPoints]) -> np.ndarray:
    """RGB whose channel c is channel c of ``colour(stacks[c])``."""
    return np.stack([colour(stack)[:, c] for c, stack in enumerate(stacks)], axis=-1)


def _path_measure(
    spec: BakeSpec, points: _PathPoints, integrator: Integrator
) -> Callable[[tuple[int, ...], str], tuple[Trial, Lut]]:
    """``refine``'s measure for a 4D LUT read along a base path: baked in memory (refine.trial_lut), scored
    at both kinds of ``points`` and held to the single-base points' ``p99_bound`` and the per-channel
    points' p99. Not their bound: a channel's base at the curve's F0 → 0 end (η3 → η1, κ3 → 0) sits by the
    base's critical angle (η3 = η1·sin θ1 at κ3 = 0), a branch point the (η3, κ3) grid interpolates across;
    where one channel is that dark the composed colour's ΔE00 magnifies it, and the per-channel 99.73rd
    percentile stayed at 1.26 for (η3, κ3) counts 16² and 32² (IridescenceAbalone) while its p99 fell."""

    def measure(counts: tuple[int, ...], label: str) -> tuple[Trial, Lut]:
        lut, nbytes, seconds = trial_lut(spec, counts, integrator)
        single, channels = points.errors(lut)
        stats = {
            kind: {"de00_p99": float(np.percentile(de, 99)), "de00_p99_bound": p99_bound(de)}
            for kind, de in (("single_base", single), ("per_channel", channels))
        }
        p99 = max(k["de00_p99"] for k in stats.values())
        gated = max(stats["single_base"]["de00_p99_bound"], stats["per_channel"]["de00_p99"])
        return Trial(tuple(counts), p99, nbytes, seconds, stats, gated), lut

    return measure
