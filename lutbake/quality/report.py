"""LUT-error reports: how wrong a LUT is, and what it cost (`lutbake report`, `sweep`, `tune`).

A report samples a LUT through the reference sampler (what a GPU returns) at
held-out points — uniform over the LUT's domain, plus the centres of random
grid cells, where multilinear interpolation error peaks — and compares with
the ground-truth integrator (lutbake/spectral/reference.py). Errors are CIEDE2000 in CIELAB
with the working space's white. The same points score the approximations
engines run today (lutbake/modes/approximations.py), so every row is measured alike.

A row's maximum is searched, not sampled (lutbake/quality/worstcase.py): from the held-out
points, the domain's corners and edges and the places where the content is
singular (D → 0, cos θ1 → 0, η3 → η1, κ3 → 0), compass steps in the LUT's node
coordinates climb the error measured against the bake's direct spectral rule
(~1e-6 from the ground truth in RGB, 60,000 points/s); the local maxima found
are then scored against the ground truth, and the row's max is the largest
ground-truth ΔE00 of all points scored. p99 and the other percentiles stay
statistics of the held-out points.

Numbers depend only on the LUT, the seed and the search budget.
"""

from __future__ import annotations

import html
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from lutbake.io.progress import no_progress
from lutbake.lut.sample import Atlas, Lut
from lutbake.modes.approximations import APPROXIMATIONS
from lutbake.modes.runtime.costs import cost_rows, cost_table_html
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.worstcase import SearchAxis, find_worst
from lutbake.spectral.reference import reference_colour

__all__ = [
    "HeldOutPoints",
    "held_out_points",
    "ErrorStats",
    "score",
    "LutReport",
    "report_lut",
    "write_report",
    "report_atlas",
    "REPORT_FILES",
    "search_max",
    "proxy_truth",
    "lut_stacks",
    "singular_places",
    "corner_distance",
    "search_slice",
    "search_stacks",
    "SEARCH_BUDGET",
    "RESCORED",
]

SEARCH_BUDGET = 20000  # evaluations of each row's worst-case search (`report`)
SLICE_SEARCH_BUDGET = 2000  # a scene atlas slice's: 2D, scored against the ground truth itself
RESCORED = 10  # distinct local maxima of a search scored against the ground truth


@dataclass
class HeldOutPoints:
    """The held-out film stacks (one film, constant bases) and their ground truth."""

    stack: FilmPoints
    kind: np.ndarray  # "uniform" or "cell-centre"
    truth: np.ndarray = None

    def __len__(self):
        return self.kind.size


def held_out_points(
    axes,
    eta1: float,
    eta2: float,
    observer: str,
    space: str,
    n_points: int,
    seed: int,
    centre_fraction: float = 0.5,
    truth=None,
) -> HeldOutPoints:
    """Uniform over the axes' domain, and a ``centre_fraction`` at centres of random cells of
    this grid (in node coordinates), where its interpolation error peaks, as float32 values (what a
    shader is given, ``shader_inputs``); their colour by ``truth`` (``stack -> RGB``; the ground truth,
    lutbake/spectral/reference.py, by default)."""
    rng = np.random.default_rng(seed)
    n_centre = int(n_points * centre_fraction)
    uniform = [rng.uniform(a.lo, a.hi, n_points - n_centre) for a in axes]
    units = np.column_stack([(rng.integers(0, a.count - 1, n_centre) + 0.5) / (a.count - 1) for a in axes])
    centres = lut_stacks(axes, eta1, eta2, units)
    coords = {
        a.name: np.concatenate([u, c])
        for a, u, c in zip(axes, uniform, (centres.cos_theta, centres.opd_nm, centres.eta3, centres.kappa3))
    }
    kind = np.array(["uniform"] * (n_points - n_centre) + ["cell-centre"] * n_centre)
    stack = shader_inputs(FilmPoints.build(eta1=eta1, eta2=eta2, **coords))
    rgb = truth(stack) if truth else reference_colour(stack, observer, space).values
    return HeldOutPoints(stack, kind, rgb)


def lut_stacks(axes, eta1: float, eta2: float, unit) -> FilmPoints:
    """Film stacks at unit node coordinates ``unit`` (n, 4) of the axes (each axis's node coordinate
    over N − 1; η3's "admittance" cells and the corner zoom's lie along cos θ1, so the other values follow
    the point's cos θ1)."""
    unit = np.asarray(unit, float)
    cos_theta = axes[0].from_unit(unit[:, 0])
    opd, eta3, kappa3 = (a.from_unit(unit[:, k], cos_theta, eta1) for k, a in enumerate(axes[1:], 1))
    return FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd, eta3=eta3, kappa3=kappa3)


def singular_places(axes, eta1: float) -> dict:
    """Where a LUT's content is singular, as worst-case search places (unit coordinates): a film of no
    thickness (D → 0), grazing incidence (cos θ1 → 0), a base that matches the ambient (η3 → η1) and a
    lossless one (κ3 → 0), each where the domain reaches it. Together they are the corner where the truth
    has no limit (docs/accuracy.md)."""
    cos_theta, opd, eta3, kappa3 = axes
    out = {}
    if opd.lo == 0.0:
        out["D → 0"] = {"opd_nm": 0.0}
    if cos_theta.lo == 0.0:
        out["cos θ → 0"] = {"cos_theta": 0.0}
    if eta3.lo <= eta1 <= eta3.hi:  # an admittance spacing starts at η1 (lutbake/grid/spec.py): u = 0 at any cos θ1
        out["η3 → η1"] = {"eta3": float(eta3.to_unit(eta1, 1.0, eta1))}
    if kappa3.lo == 0.0:
        out["κ3 → 0"] = {"kappa3": 0.0}
    return out


def corner_distance(stack: FilmPoints, wavelength_nm: float = 550.0) -> np.ndarray:
    """How far each stack is from the corner where the truth has no limit, ρ (dimensionless).

    At cos θ1 → 0 over a base that matches the ambient (η3 → η1, κ3 → 0) and a film of no thickness
    (D → 0), the Airy reflectance tends to |2(Y1 − Y3) + iφY2|² / |2(Y1 + Y3) − iφY2|² per polarization,
    with Y1 = η1 cos θ1, Y2, Y3 the film's and the base's admittances and φ the film's phase: a function
    of their ratios only, so every neighbourhood of the corner holds every value (R = 0 with no film over
    a matched base, R = 1 at grazing). ρ = max(Y1, |Y3|, φ(λ)·Y2 / 2) at ``wavelength_nm`` is the scale
    of that neighbourhood: no interpolated table is right for every ρ → 0 (docs/accuracy.md)."""
    sin2 = stack.eta1**2 * (1.0 - stack.cos_theta**2)
    y1 = stack.eta1 * stack.cos_theta
    y2 = np.sqrt(np.maximum(stack.eta2**2 - sin2, 0.0))
    y3 = np.abs(np.sqrt((stack.eta3 + 1j * stack.kappa3) ** 2 - sin2))
    phase = 2.0 * np.pi * stack.opd_nm * (y2 / stack.eta2) / wavelength_nm
    return np.maximum(np.maximum(y1, y3), 0.5 * phase * y2)


def search_max(
    read,
    lut: Lut,
    pts: HeldOutPoints,
    de00,
    proxy,
    budget: int = SEARCH_BUDGET,
    seed: int = 0,
    start_label: str = "held-out point",
    exclude=None,
) -> dict:
    """The searched maximum of ΔE00 between ``read(stack)`` and the ground truth over ``lut``'s domain.

    ``proxy(stack)`` (RGB) stands in for the ground truth while searching; the search starts from the
    scored points ``pts`` (their ground-truth ΔE00 ``de00``; ``start_label`` names them), and its distinct
    local maxima are scored against the ground truth. Returns the largest ground-truth ΔE00 of all points
    scored, where it is (``cos_theta``, ``opd_nm``, ``eta3``, ``kappa3``), how it was found, the LUT and
    truth there, the largest ΔE00 of ``pts`` and the evaluations the search spent. ``exclude(stack)``
    (a mask) leaves a region out: its points count as 0 (e.g. ``corner_distance(stack) < r``)."""
    space, observer = lut.meta["space"], lut.meta["observer"]
    axes = lut.axes
    if exclude is not None:
        de00 = np.where(exclude(pts.stack), 0.0, de00)

    def error(unit):
        stack = shader_inputs(lut_stacks(axes, lut.eta1, lut.eta2, unit))
        with np.errstate(invalid="ignore", divide="ignore"):  # NaN (a 0/0 in an approximation) is the worst
            de = delta_e00(read(stack), proxy(stack), observer, space)
        return de if exclude is None else np.where(exclude(stack), 0.0, de)

    given = np.column_stack(lut.node_coords(pts.stack)) / (np.array([a.count for a in axes]) - 1.0)
    worst = find_worst(
        error,
        tuple(SearchAxis(a.name, cells=a.count - 1) for a in axes),
        points=given,
        errors=de00,
        singular=singular_places(axes, lut.eta1),
        budget=budget,
        seed=seed,
    )
    found = worst.candidates[:RESCORED]
    how = [c.how().replace("given point", start_label, 1) for c in found]
    stack = shader_inputs(lut_stacks(axes, lut.eta1, lut.eta2, np.array([c.where for c in found])))
    truth = reference_colour(stack, observer, space).values
    with np.errstate(invalid="ignore", divide="ignore"):
        rgb = read(stack)
        scored = np.nan_to_num(delta_e00(rgb, truth, observer, space), nan=np.inf)
    if exclude is not None:
        scored = np.where(exclude(stack), 0.0, scored)
    held = int(np.argmax(de00))
    if scored.max() >= de00[held]:
        i = int(np.argmax(scored))
        at, found_by, lut_rgb, truth_rgb = _point(stack, i), how[i], rgb[i], truth[i]
    else:
        at, found_by = _point(pts.stack, held), f"{start_label} ({pts.kind[held]})"
        lut_rgb, truth_rgb = read(pts.stack)[held], pts.truth[held]
    return {
        "de00_max": float(max(scored.max(), de00[held])),
        **at,
        "found_by": found_by,
        "lut_rgb": lut_rgb.tolist(),
        "truth_rgb": truth_rgb.tolist(),
        "held_out_max": float(de00[held]),
        "evaluations": worst.evaluations,
        "budget": budget,
        "local_maxima": [
            {
                **_point(stack, i),
                "de00": float(scored[i]),
                "found_by": how[i],
                "lut_rgb": rgb[i].tolist(),
                "truth_rgb": truth[i].tolist(),
            }
            for i in range(len(found))
        ],
    }


def shader_inputs(stack: FilmPoints) -> FilmPoints:
    """The stacks at float32 values of cos θ1, D, η3 and κ3, as a shader receives them: near the grazing
    corner the search reaches ratios (η3 − η1 against cos² θ1) that float32 inputs cannot carry, and every
    path, the LUT's too, is scored against the truth at the inputs it can be given."""
    return FilmPoints.texels(
        eta1=stack.eta1,
        eta2=stack.eta2,
        **{
            name: np.asarray(getattr(stack, name), np.float32).astype(float)
            for name in ("cos_theta", "opd_nm", "eta3", "kappa3")
        },
    )


def _point(stack: FilmPoints, i: int) -> dict:
    return {
        "cos_theta": float(stack.cos_theta[i]),
        "opd_nm": float(stack.opd_nm[i]),
        "eta3": float(stack.eta3[i]),
        "kappa3": float(stack.kappa3[i]),
    }


@dataclass
class ErrorStats:
    """ΔE00 statistics of one method over the held-out points, and its searched maximum (``worst_case``,
    ``search_max``'s result) when searched: the summary's ``de00_max`` is then the searched one."""

    name: str
    de00: np.ndarray = field(repr=False)
    rgb_abs_max: float
    seconds_per_eval: float = float("nan")
    worst_case: dict = None

    def summary(self) -> dict:
        de = self.de00
        searched = self.worst_case or {}
        return {
            "name": self.name,
            "de00_mean": float(de.mean()),
            "de00_p50": float(np.percentile(de, 50)),
            "de00_p95": float(np.percentile(de, 95)),
            "de00_p99": float(np.percentile(de, 99)),
            "de00_max": searched.get("de00_max", float(de.max())),
            "rgb_abs_max": self.rgb_abs_max,
            "ns_per_eval": self.seconds_per_eval * 1e9,
            "worst_case": self.worst_case,
        }


def score(
    name: str, rgb: np.ndarray, pts: HeldOutPoints, space: str, observer: str, seconds_per_eval: float = float("nan")
) -> ErrorStats:
    de = np.nan_to_num(delta_e00(rgb, pts.truth, observer, space), nan=np.inf)
    return ErrorStats(name, de, float(np.max(np.abs(rgb - pts.truth))), seconds_per_eval)


def _timed(fn, *args):
    start = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - start


@dataclass
class LutReport:
    path: str
    meta: dict
    points: HeldOutPoints
    lut: ErrorStats
    approximations: list
    worst: list
    exact_mode_terms: dict = None  # the exact runtime mode's series terms per point, when scored
    search_budget: int = SEARCH_BUDGET
    seed: int = 0
    device: str | None = None  # the OpenCL device of the searches' stand-in truth (proxy_truth)

    def include_points(self, stack: FilmPoints, truth, de00, label: str) -> None:
        """Points scored elsewhere (e.g. the ΔE00 maps' grid) join the LUT row's maximum: where one beats
        the searched max (the search missed it), the search climbs from them and the max, its place and
        the worst points follow. The table, the maps and the JSON then state one max."""
        worst = self.lut.worst_case
        if de00.max() <= worst["de00_max"]:
            return
        lut = Lut.load(self.path)
        found = search_max(
            lut.sample,
            lut,
            HeldOutPoints(stack, np.full(len(stack), label), truth),
            de00,
            proxy_truth(lut, device=self.device),
            self.search_budget,
            self.seed,
            start_label=label,
        )
        self.lut.worst_case = {**found, "held_out_max": worst["held_out_max"]}
        self.worst = sorted(self.worst + _searched_points(found), key=lambda w: -w["de00"])[: len(self.worst)]

    def summary(self) -> dict:
        kinds, counts = np.unique(self.points.kind, return_counts=True)
        out = {
            "lut": self.path,
            "content_hash": self.meta["content_hash"],
            "points": len(self.points),
            "point_kinds": {str(k): int(c) for k, c in zip(kinds, counts)},
            "eta2": self.meta["constants"]["eta2"],
            "axes": self.meta["axes"],
            "space": self.meta["space"],
            "observer": self.meta["observer"],
            "interpolation": self.meta.get("interpolation", "linear"),
            "lut_error": self.lut.summary(),
            "approximations": [a.summary() for a in self.approximations],
            "exact_mode_terms": self.exact_mode_terms,
            "worst_points": self.worst,
        }
        if self.approximations:  # every runtime path's error beside its cost (runtime/costs.py)
            out["runtime_paths"] = cost_rows(out, self.meta["packing"]["width"] * self.meta["packing"]["height"])
        return out


def report_lut(
    path,
    n_points: int = 1000,
    seed: int = 0,
    approximations: bool = True,
    progress=no_progress,
    search_budget: int = SEARCH_BUDGET,
    device=None,
) -> LutReport:
    """Score a LUT (and the approximations) at held-out points against the ground truth, and search
    each row's maximum over the whole domain.

    Held-out points are half uniform over the LUT's domain and half at the centres of its cells (where
    interpolation errs most); the LUT is sampled from its stored texels as a GPU would. Each row's max
    is searched from them (``search_max``).

    Parameters
    ----------
    path : str or os.PathLike
        The LUT's EXR.
    n_points : int
        Held-out points.
    seed : int
        Their random seed (the same seed gives the same numbers).
    approximations : bool
        Also score the real-time approximations (Belcour & Barla; KHR_materials_iridescence / three.js),
        the exact runtime mode and, for a LUT read cubic, the same texels read by the linear rule.
    progress : callable
        ``progress(done, total, note)`` before each phase.
    search_budget : int
        Evaluations of each row's worst-case search.
    device : str, optional
        OpenCL device of the searches' stand-in truth (``proxy_truth``; see ``bake_lut``).

    Returns
    -------
    LutReport
        ``lut`` (ErrorStats: ΔE00 per point; ``summary()`` gives mean, p50, p95, p99 of the held-out
        points, the searched max with its ``worst_case``, and |ΔRGB| max), ``approximations``, the
        ``worst`` points (held-out and searched), and ``summary()`` of it all (the JSON `report` writes).

    Examples
    --------
    >>> import lutbake
    >>> axes = (lutbake.Axis("cos_theta", 0.0, 1.0, 16, "sqrt"), lutbake.Axis("opd_nm", 0.0, 1000.0, 48),
    ...         lutbake.Axis("eta3", 1.2, 2.0, 4), lutbake.Axis("kappa3", 0.0, 0.5, 2))
    >>> _ = lutbake.bake_lut(lutbake.BakeSpec(eta2=1.5, axes=axes), "coat.exr")
    >>> rep = lutbake.report_lut("coat.exr", n_points=100, search_budget=2000)
    >>> error = rep.lut.summary()
    >>> len(rep.points), error["de00_max"] >= error["worst_case"]["held_out_max"] >= error["de00_p99"]
    (100, True)
    >>> [a.name for a in rep.approximations]
    ['belcour-barla-2017', 'khr-iridescence-threejs', 'lutbake-exact-mode', 'lutbake-runtime', 'lut-linear-reads']
    """
    lut = Lut.load(path)
    space, observer = lut.meta["space"], lut.meta["observer"]
    progress(0, None, f"ground truth at {n_points} held-out points")
    pts = held_out_points(lut.axes, lut.eta1, lut.eta2, observer, space, n_points, seed)
    progress(0, None, "sampling the LUT and the approximations")
    reads = {"lut": lut.sample}
    if approximations:
        reads.update({name: (lambda stack, fn=fn: fn(stack, space, observer)) for name, fn in APPROXIMATIONS.items()})
        if lut.interpolation == "cubic":  # the same texels read by the 4-fetch rule: what cubic reads buy
            reads["lut-linear-reads"] = lambda stack: lut.sample(stack, None, "linear")
    proxy = proxy_truth(lut, device=device)
    stats, rgb = {}, {}
    for name, read in reads.items():
        rgb[name], seconds = _timed(read, pts.stack)
        stats[name] = score(name, rgb[name], pts, space, observer, seconds / len(pts))
        progress(0, None, f"searching the worst case of {name} ({search_budget} evaluations)")
        stats[name].worst_case = search_max(read, lut, pts, stats[name].de00, proxy, search_budget, seed)
    lut_stats = stats.pop("lut")
    terms = _exact_mode_terms(pts, space, observer) if approximations else None
    worst = _worst_points(pts, rgb["lut"], lut_stats)
    return LutReport(
        str(path), lut.meta, pts, lut_stats, list(stats.values()), worst, terms, search_budget, seed, device
    )


def proxy_truth(lut: Lut, backend: str = "auto", device=None):
    """``stack -> RGB`` by the bake's direct spectral rule at its default sampling, for the LUT's film
    (OpenCL on ``device``, else numpy): the truth a worst-case search climbs, ~1e-6 from the ground truth in
    RGB at 60,000 points/s (its maxima are then scored against the ground truth)."""
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.opencl import backend as make_backend

    spec = BakeSpec(
        eta2=lut.eta2, eta1=lut.eta1, axes=tuple(lut.axes), space=lut.meta["space"], observer=lut.meta["observer"]
    )
    integrator = make_backend(backend, device=device)
    return lambda stack: integrator.evaluate(spec, stack)


def _worst_points(pts: HeldOutPoints, rgb, stats: ErrorStats, count: int = 10) -> list:
    """The worst held-out points (LUT ``rgb`` there) and the search's local maxima, worst first."""
    held = [
        {
            **_point(pts.stack, i),
            "kind": str(pts.kind[i]),
            "de00": float(stats.de00[i]),
            "lut_rgb": rgb[i].tolist(),
            "truth_rgb": pts.truth[i].tolist(),
        }
        for i in np.argsort(-stats.de00, kind="stable")[:count]
    ]
    return sorted(held + _searched_points(stats.worst_case), key=lambda w: -w["de00"])[:count]


def _searched_points(worst_case: dict) -> list:
    """A search's local maxima as worst points (kind ``searched: how it was found``)."""
    return [
        {
            **{k: m[k] for k in ("cos_theta", "opd_nm", "eta3", "kappa3", "de00", "lut_rgb", "truth_rgb")},
            "kind": f"searched: {m['found_by']}",
        }
        for m in worst_case["local_maxima"]
    ]


def _exact_mode_terms(pts: HeldOutPoints, space: str, observer: str) -> dict:
    """What the exact mode's row costs per pixel: series terms at the held-out points (each term is
    4 texel fetches and ~100 scalar operations in the include, docs/engines.md)."""
    from lutbake.modes.exact import exact_mode

    terms = exact_mode(pts.stack, space, observer).terms
    return {
        "mean": float(terms.mean()),
        "p99": float(np.percentile(terms, 99)),
        "max": int(terms.max()),
        "fetches_per_term": 4,
    }


def report_atlas(
    atlas: Atlas, path, n_points: int = 1000, seed: int = 0, search_budget: int = SLICE_SEARCH_BUDGET
) -> dict:
    """Score each slice of a scene atlas, as stored, at held-out (cos θ, thickness) points against the
    ground truth of its film and base: half uniform, half at cell centres; each slice's max searched
    over its (√cos θ, thickness) node coordinates against the ground truth (``search_budget``)."""
    space, observer = atlas.meta["space"], atlas.meta["observer"]
    rng = np.random.default_rng(seed)
    slices, all_de = [], []
    for s in atlas.meta["slices"]:
        cos_t, thickness = _slice_held_out(s, n_points, rng)
        material = s["materials"][0]
        pts = FilmPoints.build(cos_theta=cos_t, thickness_nm=thickness, **atlas.film_stack(material))
        truth = reference_colour(pts, observer, space).values
        rgb = atlas.sample(material, pts)
        de = np.nan_to_num(delta_e00(rgb, truth, observer, space), nan=np.inf)
        all_de.append(de)
        stats = ErrorStats(", ".join(s["materials"]), de, float(np.max(np.abs(rgb - truth))))
        stats.worst_case = search_slice(atlas, s, cos_t, thickness, de, search_budget, seed)
        slices.append({"materials": s["materials"], "rect": s["rect"], **_untimed(stats)})
    total = ErrorStats("atlas", np.concatenate(all_de), max(r["rgb_abs_max"] for r in slices))
    total.worst_case = max((r["worst_case"] for r in slices), key=lambda w: w["de00_max"])
    return {
        "atlas": str(path),
        "scene_hash": atlas.meta["scene_hash"],
        "points": n_points * len(slices),
        "space": space,
        "observer": observer,
        "lut_error": _untimed(total),
        "slices": slices,
    }


def search_slice(atlas: Atlas, s: dict, cos_t, thickness, de00, budget: int, seed: int, proxy=None) -> dict:
    """A slice's searched max (``search_stacks``) over its (√cos θ, thickness) grid, from its held-out points
    (``de00`` their ΔE00), the grid's corners and edges and grazing incidence (and d → 0 where it reaches)."""
    material, (_, _, w, h) = s["materials"][0], s["rect"]
    lo, hi = s["axes"]["thickness_nm"]["min"], s["axes"]["thickness_nm"]["max"]

    def stack_at(unit):
        return FilmPoints.build(
            cos_theta=unit[:, 0] ** 2, thickness_nm=lo + (hi - lo) * unit[:, 1], **atlas.film_stack(material)
        )

    given = np.column_stack([np.sqrt(cos_t), (thickness - lo) / (hi - lo) if hi > lo else 0.0 * cos_t])
    places = {"cos θ → 0": {"cos_theta": 0.0}} | ({"d → 0": {"thickness_nm": 0.0}} if lo == 0.0 else {})
    axes = (SearchAxis("cos_theta", cells=w - 1), SearchAxis("thickness_nm", cells=max(h - 1, 1)))
    found = search_stacks(
        stack_at,
        lambda stack: atlas.sample(material, stack),
        axes,
        given,
        de00,
        places,
        budget,
        seed,
        atlas.meta["space"],
        atlas.meta["observer"],
        proxy,
    )
    at = found.pop("at")
    return {
        "de00_max": found.pop("de00_max"),
        "cos_theta": float(at.cos_theta[0]),
        "thickness_nm": float(at.thickness_nm[0]),
        **found,
    }


def search_stacks(
    stack_at, read, axes, given, de00, places, budget: int, seed: int, space: str, observer: str, proxy=None
) -> dict:
    """The searched max of ΔE00 between ``read(stack)`` and the ground truth over the unit box of ``axes``
    (``stack_at(unit) -> FilmPoints``): from the ``given`` points (unit coordinates, ``de00`` their ΔE00),
    the box's corners and edges and the singular ``places`` (worstcase.find_worst), climbed against the
    ground truth; or, given ``proxy`` (``stack -> RGB``, e.g. the bake's own integrator), climbed against it
    and its distinct local maxima and worst given point then scored against the ground truth, the largest
    of which is the max (``held_out_max`` that point's). Returns ``de00_max``, ``at`` (the stack there),
    ``found_by``, ``held_out_max``, ``evaluations``, ``budget``."""

    def ground_truth(stack):
        return reference_colour(stack, observer, space).values

    def error(unit, truth=proxy or ground_truth):
        stack = stack_at(unit)
        return delta_e00(read(stack), truth(stack), observer, space)

    worst = find_worst(error, axes, points=given, errors=de00, singular=places, budget=budget, seed=seed)
    found = worst.candidates[: RESCORED if proxy else 1]
    where = [c.where for c in found]
    how = [c.how().replace("given point", "held-out point", 1) for c in found]
    if proxy:  # the worst given point too, so that the max is never below the points it started from
        where, how = where + [given[int(np.argmax(de00))]], how + ["held-out point"]
    scored = error(np.array(where), ground_truth) if proxy else np.array([worst.value])
    best = int(np.argmax(scored))
    return {
        "de00_max": float(scored[best]),
        "at": stack_at(np.asarray(where[best])[None]),
        "found_by": how[best],
        "held_out_max": float(scored[-1] if proxy else np.max(de00)),
        "evaluations": worst.evaluations,
        "budget": budget,
    }


def _untimed(stats: ErrorStats) -> dict:
    return {k: v for k, v in stats.summary().items() if k != "ns_per_eval"}


def _slice_held_out(s: dict, n_points: int, rng):
    """Uniform in (√cos θ, thickness) and at centres of random cells of the slice's grid."""
    _, _, w, h = s["rect"]
    th = s["axes"]["thickness_nm"]
    n_centre = n_points // 2
    u = np.concatenate([rng.uniform(0, 1, n_points - n_centre), (rng.integers(0, w - 1, n_centre) + 0.5) / (w - 1)])
    v = np.concatenate(
        [rng.uniform(0, 1, n_points - n_centre), (rng.integers(0, max(h - 1, 1), n_centre) + 0.5) / max(h - 1, 1)]
    )
    return u**2, th["min"] + (th["max"] - th["min"]) * v


def gate(summary: dict, max_de) -> dict:
    """``summary`` with the gate verdict (p99 ΔE00 ≤ ``max_de``) added when a gate is set."""
    if max_de is not None:
        summary["gate"] = {"max_de00_p99": max_de, "passed": bool(summary["lut_error"]["de00_p99"] <= max_de)}
    return summary


# What `report --out DIR` may write there (an atlas's report: the first only).
REPORT_FILES = ("summary.json", "report.html", "delta_e_maps.png", "swatches.png")


def write_report(rep: LutReport, out_dir, maps: bool = True, max_de=None, progress=no_progress) -> dict:
    """Write ``rep`` as summary.json, PNG figures (ΔE00 maps, swatch strips) and report.html in ``out_dir``.

    Parameters
    ----------
    rep : LutReport
        From ``report_lut``.
    out_dir : str or os.PathLike
        Created if absent; each file is written atomically.
    maps : bool
        Draw the figures (ΔE00 maps and swatch strips: ground truth on grids, the slow part).
    max_de : float, optional
        Gate: adds ``gate`` (passed when p99 ΔE00 ≤ max_de) to the summary.
    progress : callable
        ``progress(done, total, note)`` before each figure.

    Returns
    -------
    dict
        The summary written to summary.json.

    Examples
    --------
    >>> import lutbake
    >>> axes = (lutbake.Axis("cos_theta", 0.0, 1.0, 16, "sqrt"), lutbake.Axis("opd_nm", 0.0, 1000.0, 48),
    ...         lutbake.Axis("eta3", 1.2, 2.0, 4), lutbake.Axis("kappa3", 0.0, 0.5, 2))
    >>> _ = lutbake.bake_lut(lutbake.BakeSpec(eta2=1.5, axes=axes), "coat.exr")
    >>> summary = lutbake.write_report(lutbake.report_lut("coat.exr", n_points=100, search_budget=2000), "report",
    ...                                maps=False, max_de=100.0)
    >>> from pathlib import Path
    >>> summary["gate"]["passed"], sorted(p.name for p in Path("report").iterdir())
    (True, ['report.html', 'summary.json'])
    """
    from lutbake.io.strictjson import dumps
    from lutbake.quality.figures import delta_e_map_panels, delta_e_maps, swatch_strips
    from lutbake.tables.lutfile import write_text_atomic

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = []
    if maps:
        panels = delta_e_map_panels(rep, progress=progress)
        for p in panels:
            rep.include_points(p.stack, p.truth, p.de00.ravel(), "map point")
        figures.append(
            (
                "ΔE00 of the LUT over (cos θ, D) at the (η3, κ3) of its worst points, the searched max marked",
                delta_e_maps(rep, panels, out / REPORT_FILES[2]),
            )
        )
        progress(0, None, "figure: swatch strips")
        figures.append(("Ground truth, LUT and approximations along D", swatch_strips(rep.path, out / REPORT_FILES[3])))
    summary = gate(rep.summary(), max_de)
    summary["figures"] = [f.name for _, f in figures]
    write_text_atomic(out / REPORT_FILES[0], dumps(summary) + "\n")
    write_text_atomic(out / REPORT_FILES[1], _html(summary, figures))
    return summary


def _html(summary: dict, figures) -> str:
    rows = [summary["lut_error"]] + summary["approximations"]
    head = (
        "<tr><th>method</th><th>mean</th><th>p50</th><th>p95</th><th>p99</th><th>max (searched)</th>"
        "<th>max |ΔRGB|</th><th>ns/eval (numpy)</th></tr>"
    )
    body = "".join(
        f"<tr><td>{html.escape(r['name'])}</td>"
        + "".join(f"<td>{r[k]:.3f}</td>" for k in ("de00_mean", "de00_p50", "de00_p95", "de00_p99", "de00_max"))
        + f"<td>{r['rgb_abs_max']:.2e}</td><td>{r['ns_per_eval']:.0f}</td></tr>"
        for r in rows
    )
    worst = "".join(
        f"<tr><td>{w['cos_theta']:.4g}</td><td>{w['opd_nm']:.4g}</td><td>{w['eta3']:.5g}</td><td>{w['kappa3']:.4g}</td>"
        f"<td>{html.escape(w['kind'])}</td><td>{w['de00']:.3f}</td></tr>"
        for w in summary["worst_points"]
    )
    searched = summary["lut_error"]["worst_case"]
    figs = "".join(f"<h2>{html.escape(t)}</h2><img src='{f.name}' style='max-width:100%'>" for t, f in figures)
    return (
        f"<!doctype html><html><head><meta charset='utf-8'><title>lutbake report</title>"
        f"<style>body{{font-family:sans-serif;margin:2em}}td,th{{padding:2px 8px;text-align:right}}</style></head><body>"
        f"<h1>LUT error report</h1><p>{html.escape(summary['lut'])}: film η2 = {summary['eta2']:g}, "
        f"{html.escape(_domain_text(summary['axes']))}; {html.escape(_points_text(summary))}, "
        f"{summary['space']} / {summary['observer']}, ΔE00 against the ground truth.</p>{_gate_html(summary)}"
        f"<p>mean, p50, p95 and p99 are statistics of the held-out points; max is each row's searched maximum "
        f"over the whole domain ({searched['budget']} evaluations from the held-out points, the domain's corners "
        f"and edges and the singular places D → 0, cos θ → 0, η3 → η1, κ3 → 0, its local maxima scored against "
        f"the ground truth). The LUT's: {searched['de00_max']:.3f} at cos θ {searched['cos_theta']:.4g}, "
        f"D {searched['opd_nm']:.4g} nm, η3 {searched['eta3']:.5g}, κ3 {searched['kappa3']:.4g} "
        f"({html.escape(searched['found_by'])}); the held-out points' largest is {searched['held_out_max']:.3f}.</p>"
        f"<table>{head}{body}</table>{cost_table_html(summary.get('runtime_paths'))}"
        f"<h2>Worst points (LUT)</h2><table><tr><th>cos θ</th><th>D (nm)</th>"
        f"<th>η3</th><th>κ3</th><th>kind</th><th>ΔE00</th></tr>{worst}</table>{figs}</body></html>\n"
    )


def _domain_text(axes) -> str:
    return ", ".join(f"{a['name']} [{a['min']:g}, {a['max']:g}]×{a['count']}" for a in axes)


def _points_text(summary: dict) -> str:
    kinds = " + ".join(f"{n} {k}" for k, n in summary["point_kinds"].items())
    return f"{summary['points']} held-out points ({kinds})"


def _gate_html(summary: dict) -> str:
    if "gate" not in summary:
        return "<p>No gate set (<code>--max-de</code>).</p>"
    g = summary["gate"]
    verdict = "PASS" if g["passed"] else "FAIL"
    colour = "#070" if g["passed"] else "#b00"
    return (
        f"<p style='font-size:1.3em;color:{colour}'><b>Gate {verdict}</b>: p99 ΔE00 "
        f"{summary['lut_error']['de00_p99']:.3f} {'≤' if g['passed'] else '>'} {g['max_de00_p99']:g}</p>"
    )
