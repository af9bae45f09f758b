"""Grow a grid until its measured p99 ΔE00 meets a target: the one refinement engine.

``refine`` knows nothing of what it grows: a caller's ``measure(counts)``
integrates a grid of those per-axis counts, rounds it to the precision it
ships in, samples it at held-out points and returns a ``Trial``. Each round
doubles, one at a time, every axis still allowed to grow and keeps the trial
that lowers p99 most per added byte; once the target is met each axis is cut
back by a quarter while it still holds. `tune` (4D LUTs), scene slices and
scene 4D jobs all run it; they differ only in their ``measure``.

Trials are integrated in memory by the bake's integrator and never written:
what a trial costs is its texels, not the file set or the bake's own
ground-truth probes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from .progress import no_progress

__all__ = ["Trial", "Refinement", "refine", "tune", "uniform_points", "TUNE_START_COUNTS", "POINT_KIND"]

TUNE_START_COUNTS = (8, 16, 4, 4)
POINT_KIND = "uniform"  # tune and sweep score uniform points only; `report` adds cell centres


@dataclass(frozen=True)
class Trial:
    """One measured grid: per-axis counts, p99 ΔE00 at the held-out points (on the stored values),
    texture bytes as stored, integration seconds, and the caller's full error statistics."""

    counts: tuple
    de00_p99: float
    bytes: int
    seconds: float
    stats: dict = field(default_factory=dict, compare=False)

    def row(self) -> dict:
        return {"shape": "×".join(map(str, self.counts)), "de00_p99": self.de00_p99,
                "bake_seconds": self.seconds, "bytes": self.bytes}


@dataclass
class Refinement:
    """The outcome: the smallest grid found (``best``), whether it meets ``target_de00_p99``, the
    accepted trials in order, and what ``measure`` built for ``best`` (e.g. the slice's values)."""

    target_de00_p99: float
    met: bool
    best: Trial
    rounds: list
    artefact: object = field(default=None, repr=False)

    @property
    def counts(self) -> tuple:
        return self.best.counts


def refine(measure, start, target: float, *, frozen=(), cap: int | None = None, max_rounds: int = 12,
           progress=no_progress, on_round=None) -> Refinement:
    """Grow ``start`` counts with ``measure(counts, label) -> (Trial, artefact)`` until p99 ≤ ``target``.

    Axes in ``frozen`` keep their count; ``cap`` bounds every count; ``on_round(trial)`` sees each
    accepted trial as it happens, ``progress(done, None, note)`` each trial before it is measured."""
    accepted = []

    def run(label, counts):
        progress(len(accepted), None, f"{label}: {'×'.join(map(str, counts))}")
        return measure(tuple(counts), label)

    def accept(trial, artefact):
        accepted.append(trial)
        if on_round:
            on_round(trial)
        return trial, artefact

    growable = [i for i in range(len(start)) if i not in frozen]
    best, artefact = accept(*run("start", start))
    for _ in range(max_rounds):
        if best.de00_p99 <= target:
            break
        trials = []
        for i in growable:
            counts = _scaled_counts(best.counts, i, 2.0, cap)
            if counts != best.counts:
                trial, built = run(f"round {len(accepted)}, axis {i} ×2", counts)
                gain = (best.de00_p99 - trial.de00_p99) / max(trial.bytes - best.bytes, 1)
                trials.append((gain, trial, built))
        if not trials:
            break  # every axis at its cap
        _, trial, built = max(trials, key=lambda t: t[0])
        best, artefact = accept(trial, built)
    met = best.de00_p99 <= target
    for i in growable if met else ():
        counts = _scaled_counts(best.counts, i, 0.75, cap)
        if counts != best.counts:
            trial, built = run(f"trim axis {i} ×0.75", counts)
            if trial.de00_p99 <= target:
                best, artefact = accept(trial, built)
    return Refinement(target, met, best, accepted, artefact)


def _scaled_counts(counts, axis: int, factor: float, cap) -> tuple:
    out = list(counts)
    out[axis] = max(2, int(round(counts[axis] * factor)))
    if cap:
        out[axis] = min(out[axis], cap)
    return tuple(out)


# --- tune: the engine over a 4D LUT's counts --------------------------------------------------

def uniform_points(spec, n_points: int, seed: int):
    """Held-out points uniform over the domain of ``spec`` with their ground truth (report.py): no
    cell centres, since the grids compared differ (a cell centre of one is a node of another)."""
    from .report import held_out_points

    return held_out_points(spec.axes, spec.eta1, spec.eta2, spec.observer, spec.space, n_points, seed,
                           centre_fraction=0.0)


def lut_measure(spec, pts, integrator):
    """``measure`` for 4D grids over ``spec``'s domain: baked in memory, rounded to the stored
    precision, sampled as a GPU would at ``pts`` and scored there."""
    from .integrate import bake_rows_all
    from .report import score
    from .sample import Lut

    stored = np.float16 if spec.precision == "half" else np.float32

    def measure(counts, label):
        grid = replace(spec, axes=tuple(replace(a, count=c) for a, c in zip(spec.axes, counts)))
        start = time.perf_counter()
        image = bake_rows_all(integrator, grid).astype(stored)
        seconds = time.perf_counter() - start
        lut = Lut.in_memory(grid, image)
        stats = score(label, lut.sample(pts.stack), pts, spec.space, spec.observer).summary()
        return Trial(tuple(counts), stats["de00_p99"], image.nbytes, seconds, stats), None

    return measure


def tune(spec, max_de: float, n_points: int = 600, seed: int = 0, backend: str = "auto", max_rounds: int = 12,
         progress=no_progress, on_round=None, start=TUNE_START_COUNTS, frozen=()) -> Refinement:
    """Smallest per-axis counts (greedy, ``refine``) whose p99 ΔE00 at ``n_points`` uniform held-out
    points meets ``max_de``, from ``start`` counts over the domain of ``spec``."""
    from .integrate import backend as make_backend

    progress(0, None, f"ground truth at {n_points} uniform points")
    pts = uniform_points(spec, n_points, seed)
    integrator = make_backend(backend, spec.compute)
    return refine(lut_measure(spec, pts, integrator), start, max_de, frozen=frozen, max_rounds=max_rounds,
                  progress=progress, on_round=on_round)


def tune_document(spec, result: Refinement) -> dict:
    """`tune --json`: the target, the counts found and their axes, the best trial's statistics, the rounds."""
    axes = [replace(a, count=c).describe() for a, c in zip(spec.axes, result.counts)]
    return {"target_de00_p99": result.target_de00_p99, "met": result.met, "counts": list(result.counts),
            "axes": axes, "interpolation": spec.interpolation, "result": {**result.best.stats, **result.best.row()}, "point_kind": POINT_KIND,
            "rounds": [t.row() for t in result.rounds]}
