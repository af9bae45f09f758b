"""Running a scene's jobs: each slice integrated (slices.py) and grown by the refinement engine
(refine.py) until its p99 ΔE00 meets the scene's target, each ranged-base job tuned and baked as a
4D LUT.

A slice's p99 is measured on its values as the atlas stores them (rounded to half or float,
sampled by the atlas sampler, sample.Atlas) against the independent ground truth (reference.py) at
held-out points; a 4D job is scored by ``refine.tune``. What a job yields: its values (slices) or
its LUT's record, and the record the cache and the manifest keep (counts, p99 reached).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .atlas import slice_header
from .bake import write_lut
from .batch import fast_colours
from .colorimetry import delta_e00
from .fileset import FileSet, sha256_file
from .integrate import backend as make_backend
from .materials import material
from .points import FilmPoints
from .reference import reference_colour
from .refine import Trial, lut_measure, refine, tune
from .report import HeldOutPoints
from .sample import Atlas
from .scene_plan import HELD_OUT_POINTS, MAX_SLICE_COUNT, TRUTH_TOLERANCE, SceneJob
from .slices import integrate_slice

__all__ = ["held_out", "refine_slice", "tuned_lut", "Device"]

_HELD_OUT = HELD_OUT_POINTS["slice"]
_LUT_MAX_ROUNDS = 6


def held_out(job: SceneJob, seed: int = 0):
    """(film stacks, truth RGB) at uniform points in √cos θ and thickness: the independent ground truth."""
    rng = np.random.default_rng(seed)
    cos_t = rng.uniform(0.0, 1.0, _HELD_OUT) ** 2
    d = rng.uniform(*job.thickness_nm, _HELD_OUT)
    pts = job.stack().points(cos_t, d)
    return pts, reference_colour(pts, job.scene.observer, job.scene.space, tolerance=TRUTH_TOLERANCE).values


def _slice_measure(job: SceneJob, held, integrator):
    """``refine``'s measure for a slice: integrated, rounded to the atlas's precision, sampled at the
    held-out points by the atlas sampler (sample.Atlas) and scored there."""
    pts, truth = held
    s, stack = job.scene, job.stack()  # one stack: it keeps what it learns about its materials' spectra
    stored = np.float16 if s.precision == "half" else np.float32

    def measure(counts, label):
        start = time.perf_counter()
        values = integrate_slice(stack, counts, job.thickness_nm, integrator, s.observer, s.space)
        seconds = time.perf_counter() - start
        image = values.astype(stored)
        rect = {**slice_header(job, [0, 0, counts[0], counts[1]]), "materials": ["slice"]}
        rgb = Atlas({"eta1": s.eta1, "slices": [rect]}, image).sample("slice", pts)
        p99 = float(np.percentile(delta_e00(rgb, truth, s.observer, s.space), 99))
        return Trial(counts, p99, image.nbytes, seconds), values

    return measure


def refine_slice(job: SceneJob, integrator, held) -> tuple:
    """The slice grown until its stored values, scored at ``held`` (``held_out``), meet the scene's
    p99 target: (values (rows, columns, 3) in float64, record)."""
    frozen = (1,) if job.fixed_thickness else ()
    result = refine(_slice_measure(job, held, integrator), job.counts, job.scene.max_de, frozen=frozen,
                    cap=MAX_SLICE_COUNT)
    record = {"counts": list(result.counts), "de00_p99": result.best.de00_p99, "held_out_points": _HELD_OUT,
              "constant_index_de00_p99": _constant_index_error(job, held, integrator)}
    return result.artefact, record


def _constant_index_error(job: SceneJob, held, integrator) -> float | None:
    """p99 ΔE00 if the slice's named materials were taken at their 550 nm index (what a
    constant-index LUT would show), at the held-out points; None without named materials."""
    film, base = job.key["film"], job.key["base"]
    if not isinstance(film, str) and not isinstance(base, str):
        return None
    pts, truth = held
    eta3, kappa3 = ((float(v) for v in material(base).index(550.0)) if isinstance(base, str) else base)
    approx_pts = FilmPoints.build(eta1=job.scene.eta1, eta2=job.film_index_550(), cos_theta=pts.cos_theta,
                                  thickness_nm=pts.thickness_nm, eta3=eta3, kappa3=kappa3)
    approx = fast_colours(approx_pts, job.scene.observer, job.scene.space, integrator)[0]  # the kernel
    return float(np.percentile(delta_e00(approx, truth, job.scene.observer, job.scene.space), 99))


def tuned_lut(job: SceneJob, path: Path, backend: str, files: FileSet) -> dict:
    """Bake the 4D LUT at the smallest counts whose p99 ΔE00 meets the target into ``files``: scored
    at uniform points of its domain (refine.tune), or along its ``base_path`` when the engine reads it
    only there; its record (counts, p99, whether the target was met, the EXR's SHA-256)."""
    spec = job.lut_spec()
    frozen = (1,) if job.fixed_thickness else ()
    if "base_path" in job.key:
        held = _path_points(spec, job.key["base_path"], HELD_OUT_POINTS["lut along a base path"])
        measure = lut_measure(spec, len(held), 0, make_backend(backend, spec.compute), None, points=held)
        result = refine(measure, job.counts, job.scene.max_de, frozen=frozen, max_rounds=_LUT_MAX_ROUNDS)
    else:
        result = tune(spec, job.scene.max_de, n_points=HELD_OUT_POINTS["lut"], seed=0, backend=backend,
                      max_rounds=_LUT_MAX_ROUNDS, start=job.counts, frozen=frozen)
    axes = tuple(replace(a, count=c) for a, c in zip(spec.axes, result.counts))
    write_lut(replace(spec, axes=axes), path, files, backend)
    return {"counts": list(result.counts), "de00_p99": result.best.de00_p99, "target_met": result.met,
            "sha256": sha256_file(files.members[path])}


def _path_points(spec, base_path, n: int, seed: int = 0) -> HeldOutPoints:
    """Held-out points of a 4D LUT read along a base curve: cos θ uniform in √cos θ, D uniform over the
    LUT's axis, (η3, κ3) at a uniform position along the curve's nodes (linear between them)."""
    rng = np.random.default_rng(seed)
    etas, kappas = (np.asarray(v, float) for v in base_path)
    at = rng.uniform(0.0, etas.size - 1.0, n)
    opd = spec.axes[1]
    stack = FilmPoints.build(eta1=spec.eta1, eta2=spec.eta2, cos_theta=rng.uniform(0.0, 1.0, n) ** 2,
                             opd_nm=rng.uniform(opd.lo, opd.hi, n), eta3=np.interp(at, np.arange(etas.size), etas),
                             kappa3=np.interp(at, np.arange(kappas.size), kappas))
    truth = reference_colour(stack, spec.observer, spec.space, tolerance=TRUTH_TOLERANCE).values
    return HeldOutPoints(stack, np.array(["uniform"] * n), truth)


class Device:
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
