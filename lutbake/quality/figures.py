"""Report figures (matplotlib, PNG): ΔE00 maps, swatch strips, the error/cost Pareto plot."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from lutbake.io.progress import no_progress
from lutbake.lut.sample import Lut
from lutbake.modes.approximations import APPROXIMATIONS
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.spectral.reference import reference_colour

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from lutbake.quality.report import LutReport

__all__ = ["MapPanel", "delta_e_map_panels", "delta_e_maps", "swatch_strips", "pareto_plot", "display_srgb"]


def _figure(figsize: tuple[float, float]) -> Figure:
    """A figure outside pyplot: no global backend switch, nothing to close (PNG through Agg on save)."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def display_srgb(rgb: npt.ArrayLike, exposure: float = 1.0) -> np.ndarray:
    """Linear RGB to clipped sRGB-encoded values for display."""
    v = np.clip(np.asarray(rgb, float) * exposure, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def _slices(lut: Lut) -> list[tuple[float, float]]:
    """Three (η3, κ3) slices: dielectric low, mid, and the most metallic corner."""
    ax = {a.name: a for a in lut.axes}
    e, k = ax["eta3"], ax["kappa3"]
    return [(e.lo, k.lo), (0.5 * (e.lo + e.hi), float(k.from_unit(0.37))), (e.hi, k.hi)]


def _stack(lut: Lut, cos_t: npt.ArrayLike, opd: npt.ArrayLike, eta3: float, kappa3: float) -> FilmPoints:
    return FilmPoints.build(eta1=lut.eta1, eta2=lut.eta2, cos_theta=cos_t, opd_nm=opd, eta3=eta3, kappa3=kappa3)


def _truth(lut: Lut, stack: FilmPoints) -> np.ndarray:
    return reference_colour(stack, lut.meta["observer"], lut.meta["space"]).values


def _worst_slices(rep: LutReport, count: int = 3) -> list[tuple[float, float]]:
    """(η3, κ3) of the worst points (the searched maximum first, then held-out and searched ones),
    distinct, worst first: where the LUT is most wrong."""
    out: list[tuple[float, float]] = []
    for w in rep.worst:
        key = (w["eta3"], w["kappa3"])
        if key not in out:
            out.append(key)
    return out[:count]


def _domain_title(lut: Lut, n_points: int) -> str:
    ax = {a.name: a for a in lut.axes}
    ranges = ", ".join(f"{name} [{a.lo:g}, {a.hi:g}]" for name, a in ax.items())
    return (
        f"film η2 = {lut.eta2:g} over {ranges}; slices through the worst points (searched, and of {n_points} held out)"
    )


@dataclass
class MapPanel:
    """ΔE00 of a LUT against the ground truth on an n × n (cos θ, D) grid at one (η3, κ3)."""

    eta3: float
    kappa3: float
    stack: FilmPoints = field(repr=False)
    truth: np.ndarray = field(repr=False)
    de00: np.ndarray = field(repr=False)  # (n, n): rows along D, columns along cos θ


def delta_e_map_panels(rep: LutReport, n: int = 48, progress: Callable[..., None] = no_progress) -> list[MapPanel]:
    """The maps' data: ΔE00 over (cos θ, D) at cell centres of an n × n grid in node coordinates, at the
    (η3, κ3) of the report's worst points (the searched maximum's first)."""
    lut = Lut.load(rep.path)
    ax = {a.name: a for a in lut.axes}
    cos_t, opd = np.meshgrid(
        ax["cos_theta"].from_unit((np.arange(n) + 0.5) / n), ax["opd_nm"].from_unit((np.arange(n) + 0.5) / n)
    )
    panels, slices = [], _worst_slices(rep)
    for i, (eta3, kappa3) in enumerate(slices):
        progress(i, len(slices), f"figure: ΔE00 map at η3 {eta3:.3f}, κ3 {kappa3:.3f} ({n * n} truth points)")
        stack = _stack(lut, cos_t.ravel(), opd.ravel(), eta3, kappa3)
        truth = _truth(lut, stack)
        de = delta_e00(lut.sample(stack), truth, lut.meta["observer"], lut.meta["space"]).reshape(n, n)
        panels.append(MapPanel(eta3, kappa3, stack, truth, de))
    return panels


def delta_e_maps(rep: LutReport, panels: list[MapPanel], out_png: str | PathLike[str]) -> Path:
    """Draw ``panels`` on one colour scale, each titled with its own p99 and max, the searched maximum
    marked (×) where its panel holds it; the title states the searched max, as the table and JSON do."""
    lut = Lut.load(rep.path)
    worst = rep.lut.summary()["worst_case"]
    vmax = max(1.0, max(float(p.de00.max()) for p in panels))
    fig = _figure((4.6 * len(panels), 4.6))
    axes = fig.subplots(1, len(panels), squeeze=False)
    n = panels[0].de00.shape[0]
    for a, p in zip(axes[0], panels):
        cos_t, opd = p.stack.cos_theta.reshape(n, n), p.stack.opd_nm.reshape(n, n)
        im = a.pcolormesh(cos_t, opd, p.de00, shading="auto", cmap="magma", vmin=0, vmax=vmax)
        if (p.eta3, p.kappa3) == (worst["eta3"], worst["kappa3"]):
            a.plot(worst["cos_theta"], worst["opd_nm"], "x", color="cyan", ms=12, mew=2.5, label="searched max")
            a.legend(fontsize=8, loc="upper right")
        a.set_title(
            f"η3 {p.eta3:.4f}, κ3 {p.kappa3:.4f}\nthis map: p99 {np.percentile(p.de00, 99):.2f}, "
            f"max {p.de00.max():.2f}",
            fontsize=10,
        )
        a.set_xlabel("cos θ", fontsize=11)
    axes[0][0].set_ylabel("D = 2·η2·d (nm)", fontsize=11)
    fig.colorbar(im, ax=axes[0].tolist(), label="ΔE00 (one scale for all panels)")
    fig.suptitle(
        f"{_domain_title(lut, len(rep.points))}\nsearched max ΔE00 {worst['de00_max']:.2f} at cos θ "
        f"{worst['cos_theta']:.4g}, D {worst['opd_nm']:.4g} nm, η3 {worst['eta3']:.4f}, κ3 "
        f"{worst['kappa3']:.4g}",
        fontsize=10,
    )
    fig.savefig(out_png, dpi=90)
    return Path(out_png)


def swatch_strips(lut_path: str | PathLike[str], out_png: str | PathLike[str], n: int = 96) -> Path:
    """Colour along D at fixed angles: ground truth, LUT, and each approximation."""
    lut = Lut.load(lut_path)
    ax = {a.name: a for a in lut.axes}
    opd = np.asarray(ax["opd_nm"].from_unit(np.linspace(0, 1, n)))
    rows = []
    for eta3, kappa3 in _slices(lut):
        for cos_t in (0.9, 0.4):
            stack = _stack(lut, cos_t, opd, eta3, kappa3)
            strips = [("ground truth", _truth(lut, stack)), ("LUT", lut.sample(stack))]
            strips += [
                (name, fn(stack, lut.meta["space"], lut.meta["observer"])) for name, fn in APPROXIMATIONS.items()
            ]
            rows.append((f"η3 {eta3:.2f} κ3 {kappa3:.2f} cos θ {cos_t}", strips))
    fig = _figure((10, 1.3 * len(rows)))
    axes = fig.subplots(len(rows), 1)
    for a, (title, strips) in zip(np.atleast_1d(axes), rows):
        exposure = 1.0 / max(np.percentile(strips[0][1], 98), 1e-3)
        image = np.stack([display_srgb(rgb, exposure) for _, rgb in strips])
        a.imshow(image, aspect="auto", extent=[opd[0], opd[-1], len(strips), 0])
        a.set_yticks(np.arange(len(strips)) + 0.5, [s for s, _ in strips], fontsize=7)
        a.set_title(title, fontsize=8, loc="left")
    np.atleast_1d(axes)[-1].set_xlabel("D (nm)")
    fig.savefig(out_png, dpi=80)
    return Path(out_png)


def pareto_plot(doc: dict[str, Any], out_png: str | PathLike[str]) -> Path:
    """p99 ΔE00 against bake time and bytes (LUT variants, cubic and linear reads), approximation rows as lines.

    Labels sit in a numbered key beside each panel, so close points never overlap."""
    rows = doc["rows"]
    fig = _figure((13, 5.2))
    a1, a2 = fig.subplots(1, 2)
    luts = [r for r in rows if r["kind"] == "lut"]
    reads = np.array([r["interpolation"] for r in luts])
    for a, key, label in ((a1, "bake_seconds", "bake time (s)"), (a2, "bytes", "LUT size (bytes)")):
        x = np.array([r[key] for r in luts])
        y = np.array([r["de00_p99"] for r in luts])
        for rule, colour, marker in (("cubic", "C0", "o"), ("linear", "C1", "s")):
            a.scatter(
                x[reads == rule],
                y[reads == rule],
                c=colour,
                marker=marker,
                zorder=3,
                label=f"LUT, {rule} reads ({'256 texel reads' if rule == 'cubic' else '4 fetches'})",
            )
        for (xv, yv), numbers in _coincident(x, y).items():
            a.annotate(",".join(numbers), (xv, yv), fontsize=8, xytext=(4, 2), textcoords="offset points")
        front = _pareto_front(x, y)
        a.plot(x[front], y[front], "C0-", lw=1, label="Pareto front (LUTs)")
        for i, r in enumerate(r for r in rows if r["kind"] == "approximation"):
            a.axhline(r["de00_p99"], color=f"C{i + 2}", ls="--", lw=1, label=f"{r['name']} (no LUT)")
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel(label)
        a.set_ylabel("p99 ΔE00")
        a.legend(fontsize=8, loc="upper right")
    key_text = "\n".join(f"{i}  {r['name']}  {r['shape']}" for i, r in enumerate(luts, start=1))
    a2.text(1.03, 1.0, key_text, transform=a2.transAxes, va="top", fontsize=8, family="monospace")
    d = doc["domain"]
    ranges = ", ".join(f"{a['name']} [{a['min']:g}, {a['max']:g}]" for a in d["axes"])
    fig.suptitle(
        f"Error against cost: film η2 = {d['eta2']:g} over {ranges}; "
        f"{doc['points']} {doc['point_kind']} held-out points",
        fontsize=11,
    )
    fig.savefig(out_png, dpi=90)
    return Path(out_png)


def _coincident(x: np.ndarray, y: np.ndarray) -> dict[tuple[float, float], list[str]]:
    """Point numbers (1-based) grouped where points fall within ~2 % of each other on log axes,
    so one label lists them all instead of several labels printing over each other."""
    groups: dict[tuple[float, float], tuple[float, float, list[str]]] = {}
    for i, (xv, yv) in enumerate(zip(x, y), start=1):
        cell = (round(float(np.log10(max(xv, 1e-300))), 2), round(float(np.log10(max(yv, 1e-300))), 2))
        groups.setdefault(cell, (xv, yv, []))[2].append(str(i))
    return {(xv, yv): numbers for xv, yv, numbers in groups.values()}


def _pareto_front(x: np.ndarray, y: np.ndarray) -> np.ndarray:

    order = np.argsort(x, kind="stable")
    front, best = [], np.inf
    for i in order:
        if y[i] < best:
            front.append(i)
            best = y[i]
    return np.array(front, dtype=int)
