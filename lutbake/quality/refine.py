"""Grow a grid until its measured p99 ΔE00 meets a target: the one refinement engine.

``refine`` knows nothing of what it grows: a caller's ``measure(counts)``
integrates a grid of those per-axis counts, rounds it to the precision it
ships in, samples it at held-out points and returns a ``Trial``. Each round
doubles, one at a time, every axis still allowed to grow and keeps the trial
that lowers its held statistic (``Trial.held``) most per added byte; once the
target is met each axis is cut back by a quarter while it still holds. `tune`
(4D LUTs), scene slices and scene 4D jobs all run it; they differ only in their
``measure``.

A target is a promise about what `report` will measure, at any seed, not about
one sample: `tune` scores the points `report` scores (half uniform, half at
centres of the trial grid's own cells) and holds to the target not their p99
but ``p99_bound``, the percentile that a fresh 1,000-point report's p99 stays
below at 99 % of seeds (99.73 %: the p99 of n points scatters by
√(0.99·0.01/n) in probability). The winning grid's maximum is then searched
(measure.search_max), so its `max` means what `report`'s does.

Trials are integrated in memory by the bake's integrator and never written:
what a trial costs is its texels, not the file set or the bake's own
ground-truth probes.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.errors import ParameterError
from lutbake.io.progress import no_progress

if TYPE_CHECKING:
    from pyopencl import Device

    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.numpy_path import NumpyBackend
    from lutbake.integrate.opencl import OpenCLBackend
    from lutbake.lut.sample import Lut
    from lutbake.quality.measure import Colours, HeldOutPoints

    Integrator = OpenCLBackend | NumpyBackend

__all__ = [
    "Trial",
    "Refinement",
    "refine",
    "tune",
    "uniform_points",
    "p99_bound",
    "bound_level",
    "mixture_percentile",
    "TUNE_START_COUNTS",
    "POINT_KIND",
    "REPORT_POINTS",
]

TUNE_START_COUNTS = (8, 16, 4, 4)
POINT_KIND = (
    "uniform"  # sweep scores uniform points only (its variants' grids differ); `report` and tune add cell centres
)
REPORT_POINTS = 1000  # `report`'s default held-out points: what a target must hold at
_SEEDS_Z = 2.326  # one-sided 99 % normal quantile: a target holds at 99 % of a report's seeds


def bound_level(report_points: int = REPORT_POINTS) -> float:
    """The percentile (0–100) below which a fresh ``report_points``-point report's p99 stays at 99 % of
    seeds: 100·(0.99 + 2.326·√(0.99·0.01 / report_points)), 99.73 for 1,000 points. The p99 of n points
    is their ⌈0.99 n⌉-th smallest, whose probability level scatters by √(0.99·0.01/n) about 0.99."""
    return 100.0 * min(0.99 + _SEEDS_Z * np.sqrt(0.99 * 0.01 / report_points), 1.0)


def p99_bound(de00: np.ndarray, report_points: int = REPORT_POINTS) -> float:
    """``de00``'s percentile at ``bound_level``: what a target is held to, so that it holds at any seed."""
    return float(np.percentile(de00, bound_level(report_points)))


def mixture_percentile(samples: Sequence[np.ndarray], percent: float) -> float:
    """The ``percent``-th percentile of the equal-weight mixture of ``samples`` (1-D arrays; each value
    of sample k weighs 1/(K·n_k)): the population a `report` draws from when it takes as many points of
    each kind. The smallest value at which the mixture's distribution reaches ``percent``."""
    values = np.concatenate(samples)
    weights = np.concatenate([np.full(len(s), 1.0 / (len(samples) * len(s))) for s in samples])
    order = np.argsort(values, kind="stable")
    reached = np.searchsorted(np.cumsum(weights[order]), percent / 100.0 * (1.0 - 1e-12))
    return float(values[order][min(int(reached), len(values) - 1)])


@dataclass(frozen=True)
class Trial:
    """One measured grid: per-axis counts, p99 ΔE00 at the held-out points (on the stored values),
    texture bytes as stored, integration seconds, the caller's full error statistics and the statistic
    the target holds (``gated``; the p99 itself when None)."""

    counts: tuple[int, ...]
    de00_p99: float
    bytes: int
    seconds: float
    stats: dict[str, Any] = field(default_factory=dict, compare=False)
    gated: float | None = None

    @property
    def held(self) -> float:
        """What ``refine`` compares with its target."""
        return self.de00_p99 if self.gated is None else self.gated

    def row(self) -> dict[str, Any]:
        return {
            "shape": "×".join(map(str, self.counts)),
            "de00_p99": self.de00_p99,
            "de00_p99_bound": self.held,
            "bake_seconds": self.seconds,
            "bytes": self.bytes,
        }


@dataclass
class Refinement:
    """The outcome: the smallest grid found (``best``), whether it meets ``target_de00_p99``, the
    accepted trials in order, and what ``measure`` built for ``best`` (e.g. the slice's values)."""

    target_de00_p99: float
    met: bool
    best: Trial
    rounds: list[Trial]
    artefact: object = field(default=None, repr=False)

    @property
    def counts(self) -> tuple[int, ...]:
        return self.best.counts


# measure(counts, label) -> (the trial, what was built for it)
Measure = Callable[[tuple[int, ...], str], tuple[Trial, object]]


def refine(
    measure: Measure,
    start: Sequence[int],
    target: float,
    *,
    frozen: Iterable[int] = (),
    cap: int | None = None,
    max_rounds: int = 12,
    progress: Callable[..., None] = no_progress,
    on_round: Callable[[Trial], object] | None = None,
) -> Refinement:
    """Grow ``start`` counts with ``measure(counts, label) -> (Trial, artefact)`` until ``Trial.held`` (the
    p99, or the bound the measure gates on) ≤ ``target``.

    Axes in ``frozen`` keep their count; ``cap`` bounds every count; ``on_round(trial)`` sees each
    accepted trial as it happens, ``progress(done, None, note)`` each trial before it is measured."""
    accepted: list[Trial] = []

    def run(label: str, counts: Sequence[int]) -> tuple[Trial, object]:
        progress(len(accepted), None, f"{label}: {'×'.join(map(str, counts))}")
        return measure(tuple(counts), label)

    def accept(trial: Trial, artefact: object) -> tuple[Trial, object]:
        accepted.append(trial)
        if on_round:
            on_round(trial)
        return trial, artefact

    growable = [i for i in range(len(start)) if i not in frozen]
    best, artefact = accept(*run("start", start))
    for _ in range(max_rounds):
        if best.held <= target:
            break
        trials = []
        for i in growable:
            counts = _scaled_counts(best.counts, i, 2.0, cap)
            if counts != best.counts:
                trial, built = run(f"round {len(accepted)}, axis {i} ×2", counts)
                gain = (best.held - trial.held) / max(trial.bytes - best.bytes, 1)
                trials.append((gain, trial, built))
        if not trials:
            break  # every axis at its cap
        _, trial, built = max(trials, key=lambda t: t[0])
        best, artefact = accept(trial, built)
    met = best.held <= target
    for i in growable if met else ():
        counts = _scaled_counts(best.counts, i, 0.75, cap)
        if counts != best.counts:
            trial, built = run(f"trim axis {i} ×0.75", counts)
            if trial.held <= target:
                best, artefact = accept(trial, built)
    return Refinement(target, met, best, accepted, artefact)


def _scaled_counts(counts: tuple[int, ...], axis: int, factor: float, cap: int | None) -> tuple[int, ...]:
    out = list(counts)
    out[axis] = max(2, int(round(counts[axis] * factor)))
    if cap:
        out[axis] = min(out[axis], cap)
    return tuple(out)


# --- tune: the engine over a 4D LUT's counts --------------------------------------------------


def uniform_points(spec: BakeSpec, n_points: int, seed: int) -> HeldOutPoints:
    """Held-out points uniform over the domain of ``spec`` with their ground truth (lutbake/quality/measure.py): what
    `sweep` scores every variant at (a cell centre of one grid is a node of another)."""
    from lutbake.quality.measure import held_out_points

    return held_out_points(
        spec.axes, spec.eta1, spec.eta2, spec.observer, spec.space, n_points, seed, centre_fraction=0.0
    )


def trial_lut(spec: BakeSpec, counts: Sequence[int], integrator: Integrator) -> tuple[Lut, int, float]:
    """``spec``'s domain at per-axis ``counts``, baked in memory by the bake's integrator and rounded to the
    stored precision: (the Lut as a GPU samples it, texture bytes, integration seconds)."""
    from lutbake.integrate.bands import bake_rows_all
    from lutbake.lut.sample import Lut

    grid = replace(spec, axes=tuple(a.resized(c) for a, c in zip(spec.axes, counts)))
    start = time.perf_counter()
    image = bake_rows_all(integrator, grid).astype(np.float16 if spec.precision == "half" else np.float32)
    return Lut.in_memory(grid, image), image.nbytes, time.perf_counter() - start


def lut_measure(spec: BakeSpec, n_points: int, seed: int, integrator: Integrator, truth: Colours) -> Measure:
    """``measure`` for 4D grids over ``spec``'s domain: baked in memory (``trial_lut``), sampled as a GPU
    would at `report`'s points for that grid (half uniform, the same for every trial; half at centres of
    its cells; their colour by ``truth``) and scored there, gated on ``p99_bound``."""
    from lutbake.quality.measure import held_out_points, score

    n_centre = n_points // 2
    uniform = held_out_points(
        spec.axes,
        spec.eta1,
        spec.eta2,
        spec.observer,
        spec.space,
        n_points - n_centre,
        seed,
        centre_fraction=0.0,
        truth=truth,
    )

    def measure(counts: tuple[int, ...], label: str) -> tuple[Trial, object]:
        lut, nbytes, seconds = trial_lut(spec, counts, integrator)
        centres = held_out_points(
            lut.axes, spec.eta1, spec.eta2, spec.observer, spec.space, n_centre, seed, centre_fraction=1.0, truth=truth
        )
        de = np.concatenate(
            [score(label, lut.sample(p.stack), p, spec.space, spec.observer).de00 for p in (uniform, centres)]
        )
        stats = {
            "de00_mean": float(de.mean()),
            "de00_p50": float(np.percentile(de, 50)),
            "de00_p95": float(np.percentile(de, 95)),
            "de00_p99": float(np.percentile(de, 99)),
            "de00_max_held_out": float(de.max()),
        }
        return Trial(tuple(counts), stats["de00_p99"], nbytes, seconds, stats, p99_bound(de)), lut.image

    return measure


def check_max_de(max_de: float) -> None:
    """ParameterError unless ``max_de`` (a target or gate on p99 ΔE00) is a number > 0.

    >>> check_max_de(0.5)
    >>> check_max_de(0.0)
    Traceback (most recent call last):
    ...
    lutbake.errors.ParameterError: max_de 0.0 is not allowed: must be a number > 0
    """
    if not max_de > 0:
        raise ParameterError("{max_de} {value} is not allowed: must be a number > 0", value=repr(max_de))


def tune(
    spec: BakeSpec,
    max_de: float,
    n_points: int = REPORT_POINTS,
    seed: int = 0,
    backend: str = "auto",
    max_rounds: int = 12,
    progress: Callable[..., None] = no_progress,
    on_round: Callable[[Trial], object] | None = None,
    start: Sequence[int] = TUNE_START_COUNTS,
    frozen: Iterable[int] = (),
    search_budget: int | None = None,
    device: str | Device | None = None,
) -> Refinement:
    """Smallest per-axis counts (greedy, ``refine``) that `report` finds within ``max_de`` at any seed:
    ``p99_bound`` of `report`'s kind of held-out points (``n_points``: half uniform, half at the trial
    grid's cell centres) ≤ ``max_de``, from ``start`` counts over the domain of ``spec``. Trials are
    scored against the bake's direct spectral rule (measure.proxy_truth: ~1e-6 from the ground truth in
    RGB, a hundred times faster; `report` then measures against the ground truth itself). The winner's
    maximum is then searched (``search_budget`` evaluations, measure.SEARCH_BUDGET by default) and put in
    its stats as ``worst_case`` and ``de00_max``. ``device``: the OpenCL device of both (see ``bake_lut``)."""
    from lutbake.integrate.opencl import backend as make_backend
    from lutbake.lut.sample import Lut
    from lutbake.quality.measure import SEARCH_BUDGET, proxy_truth

    check_max_de(max_de)
    integrator = make_backend(backend, spec.compute, device=device)
    truth = proxy_truth(Lut.in_memory(spec, None), backend, device)
    result = refine(
        lut_measure(spec, n_points, seed, integrator, truth),
        start,
        max_de,
        frozen=frozen,
        max_rounds=max_rounds,
        progress=progress,
        on_round=on_round,
    )
    progress(len(result.rounds), None, "searching the worst case of the counts found")
    worst = _searched(spec, result, n_points, seed, search_budget or SEARCH_BUDGET, backend, device)
    best = replace(result.best, stats={**result.best.stats, "de00_max": worst["de00_max"], "worst_case": worst})
    return replace(result, best=best, artefact=None)


def _searched(
    spec: BakeSpec,
    result: Refinement,
    n_points: int,
    seed: int,
    budget: int,
    backend: str,
    device: str | Device | None,
) -> dict[str, Any]:
    """measure.search_max of the winning grid, from its held-out points."""
    from lutbake.lut.sample import Lut
    from lutbake.quality.measure import held_out_points, proxy_truth, score, search_max

    grid = replace(spec, axes=tuple(a.resized(c) for a, c in zip(spec.axes, result.counts)))
    assert isinstance(result.artefact, np.ndarray)  # lut_measure's artefact: the winning grid's texels
    lut = Lut.in_memory(grid, result.artefact)
    pts = held_out_points(grid.axes, spec.eta1, spec.eta2, spec.observer, spec.space, n_points, seed)
    de = score("lut", lut.sample(pts.stack), pts, spec.space, spec.observer).de00
    return search_max(lut.sample, lut, pts, de, proxy_truth(lut, backend, device), budget, seed)


def tune_document(spec: BakeSpec, result: Refinement) -> dict[str, Any]:
    """`tune --json`: the target, the counts found and their axes, the best trial's statistics, the rounds."""
    axes = [a.resized(c).describe() for a, c in zip(spec.axes, result.counts)]
    return {
        "target_de00_p99": result.target_de00_p99,
        "met": result.met,
        "counts": list(result.counts),
        "axes": axes,
        "interpolation": spec.interpolation,
        "result": {**result.best.stats, **result.best.row()},
        "point_kinds": "half uniform, half at centres of each trial grid's cells (as `report`)",
        "gated_on": "de00_p99_bound: the 99.73th percentile, below which a fresh 1,000-point report's p99 "
        "stays at 99 % of seeds",
        "rounds": [t.row() for t in result.rounds],
    }
