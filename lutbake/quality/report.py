"""LUT-error reports: how wrong a LUT or scene atlas is, and what it cost (`lutbake report`).

A report scores a LUT, read through the reference sampler (what a GPU returns), at held-out points
against the ground truth, and beside it the approximations engines run today
(lutbake/modes/approximations.py), the exact runtime mode and the runtime table, so every row is
measured alike; each row's maximum is searched over the whole domain. The measuring tools (points,
scores, the searched max) are lutbake/quality/measure.py's; this module runs them for a LUT
(``report_lut``) or a scene atlas (``report_atlas``) and writes what they found: summary.json, figures
(lutbake/quality/figures.py) and report.html (``write_report``). p99 and the other percentiles are
statistics of the held-out points; max is the searched one.

Numbers depend only on the LUT, the seed and the search budget.
"""

from __future__ import annotations

import html
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from lutbake.io.progress import no_progress
from lutbake.lut.sample import Atlas, Lut
from lutbake.modes.approximations import APPROXIMATIONS
from lutbake.modes.runtime.costs import cost_rows, cost_table_html
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.measure import (
    SEARCH_BUDGET,
    SLICE_SEARCH_BUDGET,
    Colours,
    ErrorStats,
    HeldOutPoints,
    held_out_points,
    proxy_truth,
    remembered,
    score,
    search_max,
    search_slice,
    stack_point,
)
from lutbake.spectral.reference import reference_colour

if TYPE_CHECKING:
    from numpy.random import Generator
    from pyopencl import Device

__all__ = ["LutReport", "report_lut", "write_report", "report_atlas", "gate", "REPORT_FILES"]


def _timed(fn: Colours, *args: FilmPoints) -> tuple[np.ndarray, float]:
    start = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - start


@dataclass
class LutReport:
    path: str
    meta: dict[str, Any]
    points: HeldOutPoints
    lut: ErrorStats
    approximations: list[ErrorStats]
    worst: list[dict[str, Any]]
    exact_mode_terms: dict[str, float] | None = None  # the exact runtime mode's series terms per point, when scored
    search_budget: int = SEARCH_BUDGET
    seed: int = 0
    device: str | Device | None = None  # the OpenCL device of the searches' stand-in truth (proxy_truth)

    def include_points(self, stack: FilmPoints, truth: np.ndarray, de00: np.ndarray, label: str) -> None:
        """Points scored elsewhere (e.g. the ΔE00 maps' grid) join the LUT row's maximum: where one beats
        the searched max (the search missed it), the search climbs from them and the max, its place and
        the worst points follow. The table, the maps and the JSON then state one max."""
        worst = self.lut.worst_case
        assert worst is not None  # report_lut searched the LUT row's max
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

    def summary(self) -> dict[str, Any]:
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
    path: str | PathLike[str],
    n_points: int = 1000,
    seed: int = 0,
    approximations: bool = True,
    progress: Callable[..., None] = no_progress,
    search_budget: int = SEARCH_BUDGET,
    device: str | Device | None = None,
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
    stats, rgb = _scored_rows(lut, pts, _rows(lut, approximations), search_budget, seed, progress, device)
    lut_stats = stats.pop("lut")
    terms = _exact_mode_terms(pts, space, observer) if approximations else None
    worst = _worst_points(pts, rgb["lut"], lut_stats)
    return LutReport(
        str(path), lut.meta, pts, lut_stats, list(stats.values()), worst, terms, search_budget, seed, device
    )


def _rows(lut: Lut, approximations: bool) -> dict[str, Colours]:
    """A report's rows, name → ``read(stack) -> RGB``: the LUT, and with ``approximations`` the engines'
    approximations, the exact runtime mode, the runtime table and, for a LUT read cubic, its texels read
    by the linear rule."""
    space, observer = lut.meta["space"], lut.meta["observer"]
    reads: dict[str, Colours] = {"lut": lut.sample}
    if approximations:
        reads.update({name: partial(fn, space=space, observer=observer) for name, fn in APPROXIMATIONS.items()})
        if lut.interpolation == "cubic":  # the same texels read by the 4-fetch rule: what cubic reads buy
            reads["lut-linear-reads"] = lambda stack: lut.sample(stack, None, "linear")
    return reads


def _scored_rows(
    lut: Lut,
    pts: HeldOutPoints,
    reads: dict[str, Colours],
    search_budget: int,
    seed: int,
    progress: Callable[..., None],
    device: str | Device | None = None,
) -> tuple[dict[str, ErrorStats], dict[str, np.ndarray]]:
    """(ErrorStats, RGB at the held-out points) of each row of ``reads``, timed, its max searched over the
    whole domain (``search_max``, climbing the bake's own spectral rule: ``proxy_truth`` on ``device``)."""
    space, observer = lut.meta["space"], lut.meta["observer"]
    proxy = remembered(proxy_truth(lut, device=device))
    stats: dict[str, ErrorStats] = {}
    rgb: dict[str, np.ndarray] = {}
    for name, read in reads.items():
        rgb[name], seconds = _timed(read, pts.stack)
        stats[name] = score(name, rgb[name], pts, space, observer, seconds / len(pts))
        progress(0, None, f"searching the worst case of {name} ({search_budget} evaluations)")
        stats[name].worst_case = search_max(read, lut, pts, stats[name].de00, proxy, search_budget, seed)
    return stats, rgb


def _worst_points(pts: HeldOutPoints, rgb: np.ndarray, stats: ErrorStats, count: int = 10) -> list[dict[str, Any]]:
    """The worst held-out points (LUT ``rgb`` there) and the search's local maxima, worst first."""
    held = [
        {
            **stack_point(pts.stack, i),
            "kind": str(pts.kind[i]),
            "de00": float(stats.de00[i]),
            "lut_rgb": rgb[i].tolist(),
            "truth_rgb": pts.truth[i].tolist(),
        }
        for i in np.argsort(-stats.de00, kind="stable")[:count]
    ]
    assert stats.worst_case is not None  # every row's max is searched (_scored_rows)
    return sorted(held + _searched_points(stats.worst_case), key=lambda w: -w["de00"])[:count]


def _searched_points(worst_case: dict[str, Any]) -> list[dict[str, Any]]:
    """A search's local maxima as worst points (kind ``searched: how it was found``)."""
    return [
        {
            **{k: m[k] for k in ("cos_theta", "opd_nm", "eta3", "kappa3", "de00", "lut_rgb", "truth_rgb")},
            "kind": f"searched: {m['found_by']}",
        }
        for m in worst_case["local_maxima"]
    ]


def _exact_mode_terms(pts: HeldOutPoints, space: str, observer: str) -> dict[str, float]:
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
    atlas: Atlas,
    path: str | PathLike[str],
    n_points: int = 1000,
    seed: int = 0,
    search_budget: int = SLICE_SEARCH_BUDGET,
) -> dict[str, Any]:
    """Score each slice of a scene atlas, as stored, at held-out (cos θ, thickness) points against the
    ground truth of its film and base: half uniform, half at cell centres; each slice's max searched
    over its (√cos θ, thickness) node coordinates against the ground truth (``search_budget``)."""
    space, observer = atlas.meta["space"], atlas.meta["observer"]
    rng = np.random.default_rng(seed)
    slices: list[dict[str, Any]] = []
    all_de: list[np.ndarray] = []
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


def _untimed(stats: ErrorStats) -> dict[str, Any]:
    return {k: v for k, v in stats.summary().items() if k != "ns_per_eval"}


def _slice_held_out(s: dict[str, Any], n_points: int, rng: Generator) -> tuple[np.ndarray, np.ndarray]:
    """Uniform in (√cos θ, thickness) and at centres of random cells of the slice's grid."""
    _, _, w, h = s["rect"]
    th = s["axes"]["thickness_nm"]
    n_centre = n_points // 2
    u = np.concatenate([rng.uniform(0, 1, n_points - n_centre), (rng.integers(0, w - 1, n_centre) + 0.5) / (w - 1)])
    v = np.concatenate(
        [rng.uniform(0, 1, n_points - n_centre), (rng.integers(0, max(h - 1, 1), n_centre) + 0.5) / max(h - 1, 1)]
    )
    return u**2, th["min"] + (th["max"] - th["min"]) * v


def gate(summary: dict[str, Any], max_de: float | None) -> dict[str, Any]:
    """``summary`` with the gate verdict (p99 ΔE00 ≤ ``max_de``) added when a gate is set."""
    if max_de is not None:
        summary["gate"] = {"max_de00_p99": max_de, "passed": bool(summary["lut_error"]["de00_p99"] <= max_de)}
    return summary


# What `report --out DIR` may write there (an atlas's report: the first only).
REPORT_FILES = ("summary.json", "report.html", "delta_e_maps.png", "swatches.png")


def write_report(
    rep: LutReport,
    out_dir: str | PathLike[str],
    maps: bool = True,
    max_de: float | None = None,
    progress: Callable[..., None] = no_progress,
) -> dict[str, Any]:
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


def _html(summary: dict[str, Any], figures: Sequence[tuple[str, Path]]) -> str:
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
        f"<style>body{{font-family:sans-serif;margin:2em}}td,th{{padding:2px 8px;text-align:right}}</style>"
        "</head><body>"
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


def _domain_text(axes: Sequence[dict[str, Any]]) -> str:
    return ", ".join(f"{a['name']} [{a['min']:g}, {a['max']:g}]×{a['count']}" for a in axes)


def _points_text(summary: dict[str, Any]) -> str:
    kinds = " + ".join(f"{n} {k}" for k, n in summary["point_kinds"].items())
    return f"{summary['points']} held-out points ({kinds})"


def _gate_html(summary: dict[str, Any]) -> str:

    if "gate" not in summary:
        return "<p>No gate set (<code>--max-de</code>).</p>"
    g = summary["gate"]
    verdict = "PASS" if g["passed"] else "FAIL"
    colour = "#070" if g["passed"] else "#b00"
    return (
        f"<p style='font-size:1.3em;color:{colour}'><b>Gate {verdict}</b>: p99 ΔE00 "
        f"{summary['lut_error']['de00_p99']:.3f} {'≤' if g['passed'] else '>'} {g['max_de00_p99']:g}</p>"
    )
