"""Error against cost: sweep LUT variants over one domain (`tune` is lutbake/quality/refine.py).

Every variant is baked (timed), its file measured in bytes, and scored at the
same held-out points (uniform over the domain) as the approximations engines
run today, so the rows are comparable: p99 ΔE00 against bake seconds and
bytes for LUTs, against nanoseconds per evaluation for the approximations.
Each row's max is searched (measure.search_max, ``search_budget`` evaluations
a row, fewer than `report`'s: a sweep has ~30 rows).
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from functools import partial
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lutbake.errors import ParameterError
from lutbake.grid.spec import BakeSpec
from lutbake.io.progress import no_progress
from lutbake.lut.bake import bake
from lutbake.lut.sample import Lut
from lutbake.modes.approximations import APPROXIMATIONS
from lutbake.quality.measure import Colours, HeldOutPoints, proxy_truth, score, search_max
from lutbake.quality.refine import POINT_KIND, uniform_points

if TYPE_CHECKING:
    from pyopencl import Device

__all__ = ["sweep", "variants", "SWEEP_SEARCH_BUDGET"]

SWEEP_SEARCH_BUDGET = 5000  # evaluations of each row's worst-case search


def _scaled(spec: BakeSpec, factors: Sequence[float]) -> BakeSpec:
    axes = tuple(a.resized(max(2, int(round(a.count * f)))) for a, f in zip(spec.axes, factors))
    return replace(spec, axes=axes)


def _spaced(spec: BakeSpec, spacings: Sequence[str]) -> BakeSpec:
    return replace(spec, axes=tuple(replace(a, spacing=s) for a, s in zip(spec.axes, spacings)))


def variants(spec: BakeSpec) -> dict[str, BakeSpec]:
    """Named variants of ``spec``: resolution; parameterization (its counts on a uniform grid, on the
    √ grid: √ cos θ and κ3, uniform D and η3, and, where η3 ≥ η1, on the admittance grid: the √ grid
    with η3 on the admittance spacing, the default before sqrt-admittance); spectral sampling, storage
    and compute precision. (`sweep` scores a cubic variant's file by linear reads too.)"""
    out = {f"res×{f:g}": _scaled(spec, (f,) * 4) for f in (0.5, 1.0, 2.0)}
    out.update(
        {
            "uniform grid": _spaced(spec, ("uniform",) * 4),
            "√ grid": _spaced(spec, ("sqrt", "uniform", "uniform", "sqrt")),
        }
    )
    if spec.axes[2].lo >= spec.eta1:  # the admittance spacings are defined from η3 = η1 up
        out["admittance grid"] = _spaced(spec, ("sqrt", "uniform", "admittance", "sqrt"))
    out.update({"(cos,D)×2": _scaled(spec, (2, 2, 1, 1)), "(η3,κ3)×2": _scaled(spec, (1, 1, 2, 2))})
    out.update({f"spc {s:g}": replace(spec, samples_per_cycle=s) for s in (1.0, 2.0, 4.0)})
    out["half" if spec.precision == "float" else "float"] = replace(
        spec, precision="half" if spec.precision == "float" else "float"
    )
    out["compute float32"] = replace(spec, compute="float32")
    return out


def _scored(
    name: str,
    read: Colours,
    lut: Lut,
    pts: HeldOutPoints,
    spec: BakeSpec,
    proxy: Colours,
    budget: int,
    seconds: float = float("nan"),
) -> dict[str, Any]:
    """ErrorRow of ``read`` at ``pts``, its max searched."""
    stats = score(name, read(pts.stack), pts, spec.space, spec.observer, seconds)
    stats.worst_case = search_max(read, lut, pts, stats.de00, proxy, budget)
    return stats.summary()


def _measure(
    name: str,
    spec: BakeSpec,
    folder: str,
    pts: HeldOutPoints,
    backend: str,
    proxy: Colours,
    budget: int,
    device: str | Device | None = None,
) -> list[dict[str, Any]]:
    """The variant's row by its interpolation rule; a cubic LUT also gets a row for linear reads of the
    same file (same bytes and bake time: what the 4-fetch rule gives up)."""
    path = Path(folder) / f"{spec.content_hash[:16]}.exr"
    start = time.perf_counter()
    bake(spec, path, backend, device=device)
    seconds = time.perf_counter() - start
    lut = Lut.load(path)
    shape = "×".join(str(a.count) for a in spec.axes)
    common = {
        "kind": "lut",
        "shape": shape,
        "precision": spec.precision,
        "compute": spec.compute,
        "samples_per_cycle": spec.samples_per_cycle,
        "bake_seconds": seconds,
        "bytes": path.stat().st_size,
    }
    reads = [spec.interpolation] + (["linear"] if spec.interpolation == "cubic" else [])
    return [
        {
            **_scored(
                name if rule == spec.interpolation else f"{name} linear reads",
                partial(lut.sample, interpolation=rule),
                lut,
                pts,
                spec,
                proxy,
                budget,
            ),
            **common,
            "interpolation": rule,
        }
        for rule in reads
    ]


def _approximation_rows(spec: BakeSpec, pts: HeldOutPoints, proxy: Colours, budget: int) -> list[dict[str, Any]]:
    """The approximations' rows, their max searched over the domain of ``spec`` (in its grid's node
    coordinates: the search's steps and edge starts follow its cells)."""
    lut = Lut.in_memory(spec, None)
    rows: list[dict[str, Any]] = []
    for name, fn in APPROXIMATIONS.items():
        start = time.perf_counter()
        fn(pts.stack, spec.space, spec.observer)
        seconds = (time.perf_counter() - start) / len(pts)
        rows.append(
            {
                **_scored(
                    name,
                    partial(fn, space=spec.space, observer=spec.observer),
                    lut,
                    pts,
                    spec,
                    proxy,
                    budget,
                    seconds,
                ),
                "kind": "approximation",
            }
        )
    return rows


def sweep(
    spec: BakeSpec,
    out_dir: str | PathLike[str],
    n_points: int = 1000,
    seed: int = 0,
    backend: str = "auto",
    progress: Callable[..., None] = no_progress,
    search_budget: int = SWEEP_SEARCH_BUDGET,
    device: str | Device | None = None,
) -> dict[str, Any]:
    """Bake every variant of ``spec``; rows, a Pareto plot and sweep.json in ``out_dir``.

    ``progress(done, total, note)`` is called before each step (truth, each variant, plot); each row's
    max is searched with ``search_budget`` evaluations. ``device``: the OpenCL device of the bakes and of
    the searches' stand-in truth (see ``bake_lut``)."""
    from lutbake.io.strictjson import dumps
    from lutbake.quality.figures import pareto_plot
    from lutbake.tables.lutfile import write_text_atomic

    out = Path(out_dir)
    grid = variants(spec)  # every variant validated before anything is written
    for path in (out / "sweep.json", out / "pareto.png"):
        if out.exists() and not out.is_dir() or path.is_dir():
            raise ParameterError(
                "{out_dir} {out}: {path} cannot be written (a file or folder is in the way)",
                out=repr(str(out)),
                path=repr(str(path)),
            )
    total = len(grid) + 2
    progress(0, total, f"ground truth at {n_points} uniform points")
    pts = uniform_points(spec, n_points, seed)
    proxy = proxy_truth(Lut.in_memory(spec, None), backend, device)  # one stand-in truth for every row's search
    rows: list[dict[str, Any]] = []

    with tempfile.TemporaryDirectory() as tmp:
        for i, (name, v) in enumerate(grid.items(), start=1):
            progress(i, total, f"variant {name} ({'×'.join(str(a.count) for a in v.axes)})")
            rows += _measure(name, v, tmp, pts, backend, proxy, search_budget, device)
    progress(total - 1, total, "approximations and Pareto plot")
    rows += _approximation_rows(spec, pts, proxy, search_budget)
    doc = {
        "domain": spec.describe(),
        "points": n_points,
        "point_kind": POINT_KIND,
        "seed": seed,
        "search_budget": search_budget,
        "rows": rows,
        "figure": "pareto.png",
    }
    out.mkdir(parents=True, exist_ok=True)
    pareto_plot(doc, out / "pareto.png")
    write_text_atomic(out / "sweep.json", dumps(doc) + "\n")
    progress(total, total, "done")
    return doc
