"""Error against cost: sweep LUT variants over one domain, and tune counts to a target.

Every variant is baked (timed), its file measured in bytes, and scored at the
same held-out points (uniform over the domain) as the approximations engines
run today, so the rows are comparable: p99 ΔE00 against bake seconds and
bytes for LUTs, against nanoseconds per evaluation for the approximations.
"""

from __future__ import annotations

import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from .approximations import APPROXIMATIONS
from .bake import bake
from .plan import Axis, BakeSpec
from .report import held_out_points, score
from .sample import Lut

__all__ = ["sweep", "tune", "variants", "TUNE_START_COUNTS"]

TUNE_START_COUNTS = (8, 16, 4, 4)


def _scaled(spec: BakeSpec, factors) -> BakeSpec:
    axes = tuple(Axis(a.name, a.lo, a.hi, max(2, int(round(a.count * f))), a.spacing)
                 for a, f in zip(spec.axes, factors))
    return replace(spec, axes=axes)


def variants(spec: BakeSpec) -> dict:
    """Named variants of ``spec``: resolution, spectral sampling, storage and compute precision."""
    out = {f"res×{f:g}": _scaled(spec, (f,) * 4) for f in (0.5, 1.0, 2.0)}
    out.update({f"(cos,D)×2": _scaled(spec, (2, 2, 1, 1)), f"(η3,κ3)×2": _scaled(spec, (1, 1, 2, 2))})
    out.update({f"spc {s:g}": replace(spec, samples_per_cycle=s) for s in (1.0, 2.0, 4.0)})
    out["half" if spec.precision == "float" else "float"] = replace(
        spec, precision="half" if spec.precision == "float" else "float")
    out["compute float32"] = replace(spec, compute="float32")
    return out


def _measure(name, spec, folder, pts, backend):
    path = Path(folder) / f"{spec.content_hash[:16]}.exr"
    start = time.perf_counter()
    bake(spec, path, backend)
    seconds = time.perf_counter() - start
    lut = Lut.load(path)
    stats = score(name, lut.sample(*pts.params), pts, spec.space, spec.observer).summary()
    shape = "×".join(str(a.count) for a in spec.axes)
    return {**stats, "kind": "lut", "shape": shape, "precision": spec.precision, "compute": spec.compute,
            "samples_per_cycle": spec.samples_per_cycle, "bake_seconds": seconds, "bytes": path.stat().st_size}


def _approximation_rows(spec, pts):
    rows = []
    for name, fn in APPROXIMATIONS.items():
        start = time.perf_counter()
        rgb = fn(spec.eta1, spec.eta2, pts.params[2], pts.params[3], pts.params[0], pts.params[1],
                 spec.space, spec.observer)
        seconds = (time.perf_counter() - start) / len(pts)
        rows.append({**score(name, rgb, pts, spec.space, spec.observer, seconds).summary(), "kind": "approximation"})
    return rows


def _points_for(spec, n_points, seed):
    """Held-out points for the domain of ``spec``: uniform only, since the variants compared
    have different grids (a cell centre of one is a node of another)."""
    return held_out_points(spec.axes, spec.eta1, spec.eta2, spec.observer, spec.space, n_points, seed,
                           centre_fraction=0.0)


def sweep(spec: BakeSpec, out_dir, n_points: int = 1000, seed: int = 0, backend: str = "auto") -> dict:
    """Bake every variant of ``spec``; rows, a Pareto plot and sweep.json in ``out_dir``."""
    from .figures import pareto_plot
    from .lutfile import write_text_atomic

    out = Path(out_dir)
    grid = variants(spec)  # every variant validated before anything is written
    for path in (out / "sweep.json", out / "pareto.png"):
        if out.exists() and not out.is_dir() or path.is_dir():
            raise ValueError(f"--out {str(out)!r}: {str(path)!r} cannot be written (a file or folder is in the way)")
    with tempfile.TemporaryDirectory() as tmp:
        pts = _points_for(spec, n_points, seed)
        rows = [_measure(name, v, tmp, pts, backend) for name, v in grid.items()]
    rows += _approximation_rows(spec, pts)
    out.mkdir(parents=True, exist_ok=True)
    pareto_plot(rows, out / "pareto.png")
    doc = {"domain": spec.describe(), "points": n_points, "seed": seed, "rows": rows, "figure": "pareto.png"}
    write_text_atomic(out / "sweep.json", json.dumps(doc, indent=2) + "\n")
    return doc


def tune(spec: BakeSpec, max_de: float, n_points: int = 600, seed: int = 0, backend: str = "auto",
         max_rounds: int = 12) -> dict:
    """Smallest per-axis counts (greedy) whose p99 ΔE00 at held-out points meets ``max_de``.

    Start from 8 × 16 × 4 × 4; each round doubles the axis that lowers p99
    most per added byte, until the target is met; then each axis is cut back
    by a quarter while the target still holds.
    """
    with tempfile.TemporaryDirectory() as tmp:
        pts = _points_for(spec, n_points, seed)
        current = replace(spec, axes=tuple(replace(a, count=c) for a, c in zip(spec.axes, TUNE_START_COUNTS)))
        best = _measure("start", current, tmp, pts, backend)
        history = [best]
        for _ in range(max_rounds):
            if best["de00_p99"] <= max_de:
                break
            trials = []
            for i in range(4):
                factors = [1.0] * 4
                factors[i] = 2.0
                trial = _scaled(current, factors)
                row = _measure(f"axis {i}", trial, tmp, pts, backend)
                gain = (best["de00_p99"] - row["de00_p99"]) / max(row["bytes"] - best["bytes"], 1)
                trials.append((gain, trial, row))
            _, current, best = max(trials, key=lambda t: t[0])
            history.append(best)
        met = best["de00_p99"] <= max_de
        if met:
            for i in range(4):
                factors = [1.0] * 4
                factors[i] = 0.75
                trial = _scaled(current, factors)
                if trial.axes[i].count == current.axes[i].count:
                    continue
                row = _measure(f"trim {i}", trial, tmp, pts, backend)
                if row["de00_p99"] <= max_de:
                    current, best = trial, row
                    history.append(best)
    return {"target_de00_p99": max_de, "met": bool(met), "counts": [a.count for a in current.axes],
            "axes": [a.describe() for a in current.axes], "result": best,
            "rounds": [{k: r[k] for k in ("shape", "de00_p99", "bake_seconds", "bytes")} for r in history]}
