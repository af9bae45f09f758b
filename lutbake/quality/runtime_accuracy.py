"""How wrong the runtime path is: ΔE00 against the ground truth over the issue's domain.

Three kinds of points, each against lutbake/spectral/reference.py's converged integral at the same float32-rounded
inputs (what a GPU receives):
- random points in each base box (dielectric: η3 1–3, κ3 0–2; metal: η3 0.05–4, κ3 1.5–9; films η2
  1–3, d 0–1500 nm, cos θ 0–1) and the named metals at their per-channel indices (exact.base_rgb);
- a stress grid of the extremes: grazing incidence (cos θ down to 0), no film (d 0), films matching the
  ambient (η2 1.0001) and bases matching it (η3 1, 1.0001), the metal box's corners;
- a searched maximum per box (worstcase.find_worst: corners, edges, the singular faces, random starts,
  compass refinement), the stress grid among its starts, and one over the box's η2 ≈ η3 ≈ η1 family
  (``Ridge``); the larger of the two is the box's max (``searched_maxima``, what `lutbake report` prints
  for a runtime table and docs/make_runtime.py writes into docs/engines.md).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path

import numpy as np
import numpy.typing as npt

from lutbake.modes.runtime.files import RuntimeTable
from lutbake.modes.runtime.model import runtime_colour
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.worstcase import ErrorFunction, SearchAxis, WorstCase, find_worst
from lutbake.spectral.reference import reference_colour

__all__ = [
    "BOXES",
    "NAMED_METALS",
    "Box",
    "truth",
    "random_error",
    "stress_points",
    "box_error",
    "named_error",
    "stress_error",
    "searched_worst",
    "searched_ridge",
    "searched_named_worst",
    "searched_maxima",
    "runtime_table_summary",
    "Ridge",
]

NAMED_METALS = ("Au", "Ag", "Cu", "Al", "Fe", "Ti", "Cr")


@dataclass(frozen=True)
class Box:
    """Ranges (lo, hi) of cos θ, d (nm), η2, η3, κ3 (η1 = 1)."""

    name: str
    ranges: tuple[tuple[float, float], ...]

    def point(self, unit: np.ndarray) -> tuple[np.ndarray, ...]:
        """Columns (cos θ, d, η2[, η3, κ3]) of unit-cube points (n, len(ranges))."""
        lo, hi = np.array(self.ranges, float).T
        return tuple((lo + unit * (hi - lo)).T)

    def unit(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        """The inverse of ``point``: (n, len(ranges)) unit-cube coordinates of the columns."""
        lo, hi = np.array(self.ranges, float).T
        return (np.column_stack(columns) - lo) / (hi - lo)


_FILM = ((0.0, 1.0), (0.0, 1500.0), (1.0, 3.0))
BOXES = {
    "dielectric": Box("dielectric", _FILM + ((1.0, 3.0), (0.0, 2.0))),
    "metal": Box("metal", _FILM + ((0.05, 4.0), (1.5, 9.0))),
}


def _f32(*columns: npt.ArrayLike) -> tuple[np.ndarray, ...]:
    return tuple(np.asarray(c, np.float32).astype(float) for c in columns)


def truth(
    cos_theta: npt.ArrayLike,
    thickness_nm: npt.ArrayLike,
    eta2: npt.ArrayLike,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
) -> np.ndarray:
    """Ground truth (n, 3) with η1 = 1; η3, κ3 (n,) or (n, 3): channel c integrated with the base's c-th
    index (a point whose three indices are equal is integrated once for all three channels)."""
    eta3, kappa3 = np.asarray(eta3, float), np.asarray(kappa3, float)
    if eta3.ndim == 1:
        return reference_colour(
            FilmPoints.build(
                eta1=1.0, eta2=eta2, cos_theta=cos_theta, thickness_nm=thickness_nm, eta3=eta3, kappa3=kappa3
            )
        ).values
    cos, d, film = (np.broadcast_to(np.asarray(v, float), eta3.shape[:1]) for v in (cos_theta, thickness_nm, eta2))
    out = truth(cos, d, film, eta3[:, 0], kappa3[:, 0])
    split = np.flatnonzero(~((eta3 == eta3[:, :1]).all(axis=1) & (kappa3 == kappa3[:, :1]).all(axis=1)))
    for c in (1, 2):
        out[split, c] = truth(cos[split], d[split], film[split], eta3[split, c], kappa3[split, c])[:, c]
    return out


def _de(table: RuntimeTable, columns: Sequence[npt.ArrayLike], filter_bits: int | None = None) -> np.ndarray:
    """ΔE00 of the runtime path against the truth at float32-rounded columns (cos θ, d, η2, η3, κ3); NaN
    counts as the worst."""
    cos, d, eta2, eta3, kappa3 = _f32(*columns)
    got = runtime_colour(table, cos, d, 1.0, eta2, eta3, kappa3, filter_bits=filter_bits)
    de = delta_e00(got, truth(cos, d, eta2, eta3, kappa3))
    return np.where(np.isfinite(de), de, np.inf)


def random_error(table: RuntimeTable, box: Box, n: int, seed: int, filter_bits: int | None = None) -> np.ndarray:
    """ΔE00 at n uniform random points of ``box``."""
    return _de(table, box.point(np.random.default_rng(seed).random((n, len(box.ranges)))), filter_bits)


def stress_points(box: Box, coarse: bool = False) -> tuple[np.ndarray, ...]:
    """The extremes of ``box`` crossed with the hard values inside it (grazing, no film, matched media);
    ``coarse``: fewer values per axis (a test's budget)."""
    cos = (0.0, 1e-6, 1e-3, 0.05, 1.0) if coarse else (0.0, 1e-6, 1e-4, 1e-3, 0.01, 0.05, 0.2, 0.5, 1.0)
    d = (0.0, 1.0, 20.0, 400.0, 1500.0) if coarse else (0.0, 0.1, 1.0, 5.0, 20.0, 100.0, 400.0, 1000.0, 1500.0)
    eta2 = (1.0, 1.0001, 1.33, 3.0) if coarse else (1.0, 1.0001, 1.01, 1.33, 2.0, 3.0)
    (e_lo, e_hi), (k_lo, k_hi) = box.ranges[3], box.ranges[4]
    eta3 = sorted({e_lo, e_hi, 1.0001 if e_lo == 1.0 else 0.5} | (set() if coarse else {1.5}))
    kappa3 = sorted({k_lo, k_hi} | (set() if coarse else {0.01 if k_lo == 0.0 else 5.0}))
    grid = np.array(list(itertools.product(cos, d, eta2, eta3, kappa3)), float)
    return tuple(grid.T)


def stress_error(table: RuntimeTable, box: Box, coarse: bool = False, filter_bits: int | None = None) -> np.ndarray:
    """ΔE00 at every point of ``stress_points(box, coarse)``."""
    return _de(table, stress_points(box, coarse), filter_bits)


def box_error(table: RuntimeTable, box: Box, filter_bits: int | None = None) -> ErrorFunction:
    """ΔE00 at unit-cube points of ``box``: the error function worstcase.find_worst takes."""
    return lambda unit: _de(table, box.point(unit), filter_bits)


def named_error(table: RuntimeTable, metal: str, filter_bits: int | None = None) -> ErrorFunction:
    """ΔE00 over (cos θ, d, η2) for a named metal at its per-channel indices (unit cube, 3D)."""
    from lutbake.modes.exact import base_rgb

    n3, k3 = base_rgb(metal)
    film = Box(metal, _FILM)

    def error(unit: np.ndarray) -> np.ndarray:
        m = unit.shape[0]
        return _de(table, (*film.point(unit), np.tile(n3, (m, 1)), np.tile(k3, (m, 1))), filter_bits)

    return error


_AXES = (
    SearchAxis("cos_theta", cells=16),
    SearchAxis("thickness_nm", cells=32),
    SearchAxis("eta2", cells=16),
    SearchAxis("eta3", cells=16),
    SearchAxis("kappa3", cells=16),
)
# Faces where the physics is singular: grazing incidence, no film, a film matching the ambient, and
# (where the box reaches them) a base matching the ambient or without absorption.
_SINGULAR = {
    "grazing": {"cos_theta": 0.0},
    "no film": {"thickness_nm": 0.0},
    "film = ambient": {"eta2": 0.0},
    "base = ambient": {"eta3": 0.0},
    "lossless base": {"kappa3": 0.0},
}


def searched_worst(
    table: RuntimeTable,
    box: Box,
    budget: int = 6000,
    seed: int = 0,
    filter_bits: int | None = None,
    full_stress: bool = False,
) -> WorstCase:
    """worstcase.find_worst over ``box`` (unit coordinates linear in cos θ, d, η2, η3, κ3), the stress grid
    (coarse, or the full one, scored first and not counted in the budget) among its starts."""
    stress = stress_points(box, coarse=not full_stress)
    errors = stress_error(table, box, coarse=not full_stress, filter_bits=filter_bits) if full_stress else None
    return find_worst(
        box_error(table, box, filter_bits),
        _AXES,
        points=box.unit(stress),
        errors=errors,
        singular=_SINGULAR,
        budget=budget,
        seed=seed,
    )


@dataclass(frozen=True)
class Ridge:
    """The η2 ≈ η3 ≈ η1 family of ``box`` in coordinates that resolve it, unit (cos θ, X, s, t, κ3):
    cos θ = COS_MAX u², the film's optical path X = 2 d g2 = X_MAX u² (the table's own axis: its slices are
    uniform in √X, one search cell each), η2 = 1 + 10^(LOG_LO + (LOG_HI − LOG_LO) s) (offsets from the ambient
    by decades), η3 = 1 + RATIO_MAX t (η2 − 1) (the ridge η3 = η2 is t = 1/RATIO_MAX: an axis here, a diagonal in
    the box's coordinates), clipped to the box, as d = X/(2 g2) is; κ3 as in the box. In the box's
    coordinates the error there is a narrow line in (cos θ, d, η2) that a compass search of cells 0.06 in η
    wide steps over (ΔE00 0.23 at cos θ 0.0212, d 659 nm, η2 = η3 = 1.0226, κ3 1.477 against its 0.18)."""

    box: Box
    COS_MAX = 0.25
    X_MAX_NM = 9000.0
    LOG_LO, LOG_HI = -4.0, -0.5
    RATIO_MAX = 3.0

    def point(self, unit: np.ndarray) -> tuple:
        """Columns (cos θ, d, η2, η3, κ3) of unit points (n, 5)."""
        (d_lo, d_hi), (e_lo, e_hi), (k_lo, k_hi) = self.box.ranges[1], self.box.ranges[3], self.box.ranges[4]
        cos = self.COS_MAX * unit[:, 0] ** 2
        eta2 = 1.0 + 10.0 ** (self.LOG_LO + (self.LOG_HI - self.LOG_LO) * unit[:, 2])
        g2 = np.sqrt((eta2 - 1.0) * (eta2 + 1.0) + cos * cos)
        thickness = np.clip(self.X_MAX_NM * unit[:, 1] ** 2 / (2.0 * g2), d_lo, d_hi)
        eta3 = np.clip(1.0 + self.RATIO_MAX * unit[:, 3] * (eta2 - 1.0), e_lo, e_hi)
        return cos, thickness, eta2, eta3, k_lo + unit[:, 4] * (k_hi - k_lo)


# One cell per table slice along √X; 14 half-decades of η2 − η1; η3's offset in twelfths of RATIO_MAX.
_RIDGE_AXES = tuple(
    SearchAxis(name, cells=cells)
    for name, cells in (
        ("sqrt_cos_theta", 16),
        ("sqrt_x", 128),
        ("log_eta2_offset", 14),
        ("eta3_offset_ratio", 12),
        ("kappa3", 16),
    )
)
_RIDGE_SINGULAR = {"grazing": {"sqrt_cos_theta": 0.0}, "base = film": {"eta3_offset_ratio": 1.0 / Ridge.RATIO_MAX}}


def searched_ridge(
    table: RuntimeTable,
    box: Box,
    budget: int = 6000,
    scatter: int = 30000,
    seed: int = 0,
    filter_bits: int | None = None,
) -> WorstCase:
    """worstcase.find_worst over ``Ridge(box)``, started from ``scatter`` random points as well (scored first,
    not counted in ``budget``): the error there is a field of narrow peaks, one per table cell the films'
    (X, z) cross, that a search needs many starts to land near. ``Ridge(box).point(worst.where[None])`` names
    the place."""
    ridge = Ridge(box)

    def error(unit: np.ndarray) -> np.ndarray:
        return _de(table, ridge.point(unit), filter_bits)

    starts = np.random.default_rng(seed).random((scatter, len(_RIDGE_AXES)))
    errors = np.concatenate([error(part) for part in np.array_split(starts, max(scatter // 2000, 1))])
    return find_worst(
        error, _RIDGE_AXES, points=starts, errors=errors, singular=_RIDGE_SINGULAR, budget=budget, seed=seed
    )


def searched_named_worst(table: RuntimeTable, metal: str, budget: int = 2000, seed: int = 0) -> WorstCase:
    """worstcase.find_worst over (cos θ, d, η2) for a named metal at its per-channel indices."""
    singular = {k: v for k, v in _SINGULAR.items() if set(v) <= {"cos_theta", "thickness_nm", "eta2"}}
    return find_worst(named_error(table, metal), _AXES[:3], singular=singular, budget=budget, seed=seed)


def _found(worst: WorstCase, columns: tuple, evaluations: int) -> dict:
    """A search's max, where it sits (cos θ, d nm, η2, η3, κ3) and what it cost."""
    at = dict(zip(("cos_theta", "thickness_nm", "eta2", "eta3", "kappa3"), (float(c[0]) for c in columns)))
    return {"max": worst.value, "at": at, "evaluations": evaluations, "found_by": worst.best.how()}


def searched_maxima(
    table: RuntimeTable, budget: int = 6000, scatter: int = 30000, filter_bits: int | None = None
) -> dict[str, dict]:
    """Per box: the box's search (``searched_worst``, the full stress grid among its starts, seed 1) and the
    ridge's (``searched_ridge``, ``scatter`` random starts, seed 0), each ``budget`` evaluations; the box's
    max, where and evaluations are the larger search's (evaluations: both searches')."""
    out = {}
    for name, box in BOXES.items():
        worst = searched_worst(table, box, budget=budget, seed=1, filter_bits=filter_bits, full_stress=True)
        found = {"box": _found(worst, box.point(worst.where[None]), worst.evaluations)}
        worst = searched_ridge(table, box, budget=budget, scatter=scatter, seed=0, filter_bits=filter_bits)
        found["ridge"] = _found(worst, Ridge(box).point(worst.where[None]), worst.evaluations + scatter)
        best = max(found.values(), key=lambda r: r["max"])
        total = sum(r["evaluations"] for r in found.values())
        out[name] = {**found, "max": best["max"], "at": best["at"], "evaluations": total}
    return out


def runtime_table_summary(
    table: RuntimeTable,
    n_points: int = 1000,
    seed: int = 0,
    budget: int = 6000,
    out_dir: str | PathLike[str] | None = None,
    max_de: float | None = None,
) -> dict:
    """`lutbake report` of a runtime table: per box, ΔE00 p99 and max at ``n_points`` random points (seed
    ``seed``) and the searched maxima (``searched_maxima``, ``budget`` evaluations a search, 5 × ``budget``
    ridge starts: 30,000 at the default, as docs/engines.md's figures). Its row (``lut_error``): the worst
    box's p99 and searched max. Written to ``out_dir``/summary.json when given, then gated by ``max_de``."""
    from lutbake.io.strictjson import dumps
    from lutbake.quality.report import REPORT_FILES, gate
    from lutbake.tables.lutfile import write_text_atomic

    searched = searched_maxima(table, budget=budget, scatter=5 * budget)
    boxes = {}
    for name, box in BOXES.items():
        de = random_error(table, box, n_points, seed)
        held_out = {"points": n_points, "p99": float(np.percentile(de, 99)), "max": float(de.max())}
        boxes[name] = {"held_out": held_out, **searched[name]}
    row = {
        "name": "lutbake-runtime",
        "de00_p99": max(b["held_out"]["p99"] for b in boxes.values()),
        "de00_max": max(b["max"] for b in boxes.values()),
    }
    summary = {"kind": "runtime", "content_hash": table.meta["content_hash"], "lut_error": row, "boxes": boxes}
    if out_dir:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
        write_text_atomic(Path(out_dir) / REPORT_FILES[0], dumps(summary) + "\n")
    return gate(summary, max_de)
