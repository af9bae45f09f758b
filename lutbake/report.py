"""LUT-error reports: how wrong a LUT is, and what it cost (`lutbake report`, `sweep`, `tune`).

A report samples a LUT through the reference sampler (what a GPU returns) at
held-out points — uniform over the LUT's domain, plus the centres of random
grid cells, where multilinear interpolation error peaks — and compares with
the ground-truth integrator (reference.py). Errors are CIEDE2000 in CIELAB
with the working space's white. The same points score the approximations
engines run today (approximations.py), so every row is measured alike.

Numbers depend only on the LUT and the seed.
"""

from __future__ import annotations

import html
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .approximations import APPROXIMATIONS
from .colorimetry import delta_e00
from .points import FilmPoints
from .progress import no_progress
from .reference import reference_colour
from .runtime.costs import cost_rows, cost_table_html
from .sample import Atlas, Lut

__all__ = ["HeldOutPoints", "held_out_points", "ErrorStats", "score", "LutReport", "report_lut",
           "write_report", "report_atlas", "REPORT_FILES"]


@dataclass
class HeldOutPoints:
    """The held-out film stacks (one film, constant bases) and their ground truth."""

    stack: FilmPoints
    kind: np.ndarray  # "uniform" or "cell-centre"
    truth: np.ndarray = None

    def __len__(self):
        return self.kind.size


def held_out_points(axes, eta1: float, eta2: float, observer: str, space: str, n_points: int,
                    seed: int, centre_fraction: float = 0.5) -> HeldOutPoints:
    """Uniform over the axes' domain, and a ``centre_fraction`` at centres of random cells of
    this grid (in node coordinates), where its interpolation error peaks."""
    rng = np.random.default_rng(seed)
    n_centre = int(n_points * centre_fraction)
    uniform = [rng.uniform(a.lo, a.hi, n_points - n_centre) for a in axes]
    units = [(rng.integers(0, a.count - 1, n_centre) + 0.5) / (a.count - 1) for a in axes]
    snell2 = eta1 ** 2 * (1.0 - axes[0].from_unit(units[0]) ** 2)   # η3's "admittance" cells lie along cos θ
    centres = [a.from_unit(u, snell2) for a, u in zip(axes, units)]
    coords = {a.name: np.concatenate([u, c]) for a, u, c in zip(axes, uniform, centres)}
    kind = np.array(["uniform"] * (n_points - n_centre) + ["cell-centre"] * n_centre)
    stack = FilmPoints.build(eta1=eta1, eta2=eta2, **coords)
    return HeldOutPoints(stack, kind, reference_colour(stack, observer, space).values)


@dataclass
class ErrorStats:
    """ΔE00 statistics of one method over the held-out points."""

    name: str
    de00: np.ndarray = field(repr=False)
    rgb_abs_max: float
    seconds_per_eval: float = float("nan")

    def summary(self) -> dict:
        de = self.de00
        return {"name": self.name, "de00_mean": float(de.mean()), "de00_p50": float(np.percentile(de, 50)),
                "de00_p95": float(np.percentile(de, 95)), "de00_p99": float(np.percentile(de, 99)),
                "de00_max": float(de.max()), "rgb_abs_max": self.rgb_abs_max,
                "ns_per_eval": self.seconds_per_eval * 1e9}


def score(name: str, rgb: np.ndarray, pts: HeldOutPoints, space: str, observer: str,
          seconds_per_eval: float = float("nan")) -> ErrorStats:
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
    exact_mode_terms: dict = None   # the exact runtime mode's series terms per point, when scored

    def summary(self) -> dict:
        kinds, counts = np.unique(self.points.kind, return_counts=True)
        out = {"lut": self.path, "content_hash": self.meta["content_hash"], "points": len(self.points),
                "point_kinds": {str(k): int(c) for k, c in zip(kinds, counts)},
                "eta2": self.meta["constants"]["eta2"], "axes": self.meta["axes"],
                "space": self.meta["space"], "observer": self.meta["observer"],
                "interpolation": self.meta.get("interpolation", "linear"),
                "lut_error": self.lut.summary(), "approximations": [a.summary() for a in self.approximations],
                "exact_mode_terms": self.exact_mode_terms, "worst_points": self.worst}
        if self.approximations:   # every runtime path's error beside its cost (runtime/costs.py)
            out["runtime_paths"] = cost_rows(out, self.meta["packing"]["width"] * self.meta["packing"]["height"])
        return out


def report_lut(path, n_points: int = 1000, seed: int = 0, approximations: bool = True,
               progress=no_progress) -> LutReport:
    """Score a LUT (and the approximations) at held-out points against the ground truth.

    Held-out points are half uniform over the LUT's domain and half at the centres of its cells (where
    interpolation errs most); the LUT is sampled from its stored texels as a GPU would.

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

    Returns
    -------
    LutReport
        ``lut`` (ErrorStats: ΔE00 per point; ``summary()`` gives mean, p50, p95, p99, max and |ΔRGB| max),
        ``approximations``, the ``worst`` points, and ``summary()`` of it all (the JSON `report` writes).

    Examples
    --------
    >>> import lutbake
    >>> axes = (lutbake.Axis("cos_theta", 0.0, 1.0, 16, "sqrt"), lutbake.Axis("opd_nm", 0.0, 1000.0, 48),
    ...         lutbake.Axis("eta3", 1.2, 2.0, 4), lutbake.Axis("kappa3", 0.0, 0.5, 2))
    >>> _ = lutbake.bake_lut(lutbake.BakeSpec(eta2=1.5, axes=axes), "coat.exr")
    >>> rep = lutbake.report_lut("coat.exr", n_points=100)
    >>> error = rep.lut.summary()
    >>> len(rep.points), error["de00_max"] >= error["de00_p99"] >= error["de00_p50"]
    (100, True)
    >>> [a.name for a in rep.approximations]
    ['belcour-barla-2017', 'khr-iridescence-threejs', 'lutbake-exact-mode', 'lutbake-runtime', 'lut-linear-reads']
    """
    lut = Lut.load(path)
    space, observer = lut.meta["space"], lut.meta["observer"]
    progress(0, None, f"ground truth at {n_points} held-out points")
    pts = held_out_points(lut.axes, lut.eta1, lut.eta2, observer, space, n_points, seed)
    progress(0, None, "sampling the LUT and the approximations")
    rgb, seconds = _timed(lut.sample, pts.stack)
    lut_stats = score("lut", rgb, pts, space, observer, seconds / len(pts))
    rows = []
    if approximations:
        for name, fn in APPROXIMATIONS.items():
            out, seconds = _timed(fn, pts.stack, space, observer)
            rows.append(score(name, out, pts, space, observer, seconds / len(pts)))
        if lut.interpolation == "cubic":  # the same texels read by the 4-fetch rule: what cubic reads buy
            out, seconds = _timed(lut.sample, pts.stack, None, "linear")
            rows.append(score("lut-linear-reads", out, pts, space, observer, seconds / len(pts)))
    terms = _exact_mode_terms(pts, space, observer) if approximations else None
    order = np.argsort(-lut_stats.de00, kind="stable")[:10]
    film, opd = pts.stack, pts.stack.opd_nm
    worst = [{"cos_theta": float(film.cos_theta[i]), "opd_nm": float(opd[i]), "eta3": float(film.eta3[i]),
              "kappa3": float(film.kappa3[i]), "kind": str(pts.kind[i]),
              "de00": float(lut_stats.de00[i]), "lut_rgb": rgb[i].tolist(), "truth_rgb": pts.truth[i].tolist()}
             for i in order]
    return LutReport(str(path), lut.meta, pts, lut_stats, rows, worst, terms)


def _exact_mode_terms(pts: HeldOutPoints, space: str, observer: str) -> dict:
    """What the exact mode's row costs per pixel: series terms at the held-out points (each term is
    4 texel fetches and ~100 scalar operations in the include, docs/engines.md)."""
    from .exact import exact_mode

    terms = exact_mode(pts.stack, space, observer).terms
    return {"mean": float(terms.mean()), "p99": float(np.percentile(terms, 99)), "max": int(terms.max()),
            "fetches_per_term": 4}


def report_atlas(atlas: Atlas, path, n_points: int = 1000, seed: int = 0) -> dict:
    """Score each slice of a scene atlas, as stored, at held-out (cos θ, thickness) points against the
    ground truth of its film and base: half uniform, half at cell centres."""
    space, observer = atlas.meta["space"], atlas.meta["observer"]
    rng = np.random.default_rng(seed)
    slices, all_de = [], []
    for s in atlas.meta["slices"]:
        cos_t, thickness = _slice_held_out(s, n_points, rng)
        pts = FilmPoints.build(cos_theta=cos_t, thickness_nm=thickness, **atlas.film_stack(s["materials"][0]))
        truth = reference_colour(pts, observer, space).values
        rgb = atlas.sample(s["materials"][0], pts)
        de = np.nan_to_num(delta_e00(rgb, truth, observer, space), nan=np.inf)
        all_de.append(de)
        stats = ErrorStats(", ".join(s["materials"]), de, float(np.max(np.abs(rgb - truth))))
        slices.append({"materials": s["materials"], "rect": s["rect"], **_untimed(stats)})
    total = ErrorStats("atlas", np.concatenate(all_de), max(r["rgb_abs_max"] for r in slices))
    return {"atlas": str(path), "scene_hash": atlas.meta["scene_hash"], "points": n_points * len(slices),
            "space": space, "observer": observer, "lut_error": _untimed(total), "slices": slices}


def _untimed(stats: ErrorStats) -> dict:
    return {k: v for k, v in stats.summary().items() if k != "ns_per_eval"}


def _slice_held_out(s: dict, n_points: int, rng):
    """Uniform in (√cos θ, thickness) and at centres of random cells of the slice's grid."""
    _, _, w, h = s["rect"]
    th = s["axes"]["thickness_nm"]
    n_centre = n_points // 2
    u = np.concatenate([rng.uniform(0, 1, n_points - n_centre), (rng.integers(0, w - 1, n_centre) + 0.5) / (w - 1)])
    v = np.concatenate([rng.uniform(0, 1, n_points - n_centre),
                        (rng.integers(0, max(h - 1, 1), n_centre) + 0.5) / max(h - 1, 1)])
    return u ** 2, th["min"] + (th["max"] - th["min"]) * v


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
    >>> summary = lutbake.write_report(lutbake.report_lut("coat.exr", n_points=100), "report", maps=False,
    ...                                max_de=100.0)
    >>> from pathlib import Path
    >>> summary["gate"]["passed"], sorted(p.name for p in Path("report").iterdir())
    (True, ['report.html', 'summary.json'])
    """
    from .figures import delta_e_maps, swatch_strips
    from .lutfile import write_text_atomic
    from .strictjson import dumps

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = gate(rep.summary(), max_de)
    figures = []
    if maps:
        figures.append(("ΔE00 of the LUT over (cos θ, D) at the (η3, κ3) of its worst held-out points",
                        delta_e_maps(rep, out / REPORT_FILES[2], progress=progress)))
        progress(0, None, "figure: swatch strips")
        figures.append(("Ground truth, LUT and approximations along D", swatch_strips(rep.path, out / REPORT_FILES[3])))
    summary["figures"] = [f.name for _, f in figures]
    write_text_atomic(out / REPORT_FILES[0], dumps(summary) + "\n")
    write_text_atomic(out / REPORT_FILES[1], _html(summary, figures))
    return summary


def _html(summary: dict, figures) -> str:
    rows = [summary["lut_error"]] + summary["approximations"]
    head = "<tr><th>method</th><th>mean</th><th>p50</th><th>p95</th><th>p99</th><th>max</th><th>max |ΔRGB|</th><th>ns/eval (numpy)</th></tr>"
    body = "".join(
        f"<tr><td>{html.escape(r['name'])}</td>" + "".join(f"<td>{r[k]:.3f}</td>" for k in
        ("de00_mean", "de00_p50", "de00_p95", "de00_p99", "de00_max")) +
        f"<td>{r['rgb_abs_max']:.2e}</td><td>{r['ns_per_eval']:.0f}</td></tr>" for r in rows)
    worst = "".join(
        f"<tr><td>{w['cos_theta']:.4f}</td><td>{w['opd_nm']:.1f}</td><td>{w['eta3']:.3f}</td><td>{w['kappa3']:.3f}</td>"
        f"<td>{w['kind']}</td><td>{w['de00']:.3f}</td></tr>" for w in summary["worst_points"])
    figs = "".join(f"<h2>{html.escape(t)}</h2><img src='{f.name}' style='max-width:100%'>" for t, f in figures)
    return (f"<!doctype html><html><head><meta charset='utf-8'><title>lutbake report</title>"
            f"<style>body{{font-family:sans-serif;margin:2em}}td,th{{padding:2px 8px;text-align:right}}</style></head><body>"
            f"<h1>LUT error report</h1><p>{html.escape(summary['lut'])}: film η2 = {summary['eta2']:g}, "
            f"{html.escape(_domain_text(summary['axes']))}; {html.escape(_points_text(summary))}, "
            f"{summary['space']} / {summary['observer']}, ΔE00 against the ground truth.</p>{_gate_html(summary)}"
            f"<table>{head}{body}</table>{cost_table_html(summary.get('runtime_paths'))}<h2>Worst points (LUT)</h2><table><tr><th>cos θ</th><th>D (nm)</th>"
            f"<th>η3</th><th>κ3</th><th>kind</th><th>ΔE00</th></tr>{worst}</table>{figs}</body></html>\n")


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
    return (f"<p style='font-size:1.3em;color:{colour}'><b>Gate {verdict}</b>: p99 ΔE00 "
            f"{summary['lut_error']['de00_p99']:.3f} {'≤' if g['passed'] else '>'} {g['max_de00_p99']:g}</p>")
