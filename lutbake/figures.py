"""Report figures (matplotlib, PNG): ΔE00 maps, swatch strips, the error/cost Pareto plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .approximations import APPROXIMATIONS
from .colorimetry import delta_e00
from .points import FilmPoints
from .reference import reference_colour
from .sample import Lut

__all__ = ["delta_e_maps", "swatch_strips", "pareto_plot", "display_srgb"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def display_srgb(rgb, exposure=1.0):
    """Linear RGB to clipped sRGB-encoded values for display."""
    v = np.clip(np.asarray(rgb, float) * exposure, 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def _slices(lut: Lut):
    """Three (η3, κ3) slices: dielectric low, mid, and the most metallic corner."""
    ax = {a.name: a for a in lut.axes}
    e, k = ax["eta3"], ax["kappa3"]
    return [(e.lo, k.lo), (0.5 * (e.lo + e.hi), k.from_unit(0.37)), (e.hi, k.hi)]


def _truth(lut, cos_t, opd, eta3, kappa3):
    pts = FilmPoints.build(eta1=lut.eta1, eta2=lut.eta2, cos_theta=cos_t, opd_nm=opd, eta3=eta3, kappa3=kappa3)
    return reference_colour(pts, lut.meta["observer"], lut.meta["space"]).values


def delta_e_maps(lut_path, out_png: Path, n: int = 40) -> Path:
    """ΔE00 of the LUT against the ground truth over (cos θ, D) at three (η3, κ3)."""
    plt = _pyplot()
    lut = Lut.load(lut_path)
    ax = {a.name: a for a in lut.axes}
    cos_t, opd = np.meshgrid(ax["cos_theta"].from_unit((np.arange(n) + 0.5) / n),
                             ax["opd_nm"].from_unit((np.arange(n) + 0.5) / n))
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.8), constrained_layout=True)
    for a, (eta3, kappa3) in zip(axes, _slices(lut)):
        truth = _truth(lut, cos_t.ravel(), opd.ravel(), eta3, kappa3)
        de = delta_e00(lut.sample(cos_t.ravel(), opd.ravel(), eta3, kappa3), truth,
                       lut.meta["observer"], lut.meta["space"]).reshape(n, n)
        im = a.pcolormesh(cos_t, opd, de, shading="auto", cmap="magma", vmin=0, vmax=max(1.0, float(de.max())))
        a.set_title(f"η3 {eta3:.2f}, κ3 {kappa3:.2f}: p99 {np.percentile(de, 99):.2f}, max {de.max():.2f}", fontsize=9)
        a.set_xlabel("cos θ")
        fig.colorbar(im, ax=a, label="ΔE00")
    axes[0].set_ylabel("D (nm)")
    fig.savefig(out_png, dpi=80)
    plt.close(fig)
    return Path(out_png)


def swatch_strips(lut_path, out_png: Path, n: int = 96) -> Path:
    """Colour along D at fixed angles: ground truth, LUT, and each approximation."""
    plt = _pyplot()
    lut = Lut.load(lut_path)
    ax = {a.name: a for a in lut.axes}
    opd = ax["opd_nm"].from_unit(np.linspace(0, 1, n))
    rows = []
    for eta3, kappa3 in _slices(lut):
        for cos_t in (0.9, 0.4):
            truth = _truth(lut, np.full(n, cos_t), opd, eta3, kappa3)
            strips = [("ground truth", truth), ("LUT", lut.sample(cos_t, opd, eta3, kappa3))]
            strips += [(name, fn(lut.eta1, lut.eta2, eta3, kappa3, cos_t, opd, lut.meta["space"],
                                 lut.meta["observer"])) for name, fn in APPROXIMATIONS.items()]
            rows.append((f"η3 {eta3:.2f} κ3 {kappa3:.2f} cos θ {cos_t}", strips))
    fig, axes = plt.subplots(len(rows), 1, figsize=(10, 1.3 * len(rows)), constrained_layout=True)
    for a, (title, strips) in zip(np.atleast_1d(axes), rows):
        exposure = 1.0 / max(np.percentile(strips[0][1], 98), 1e-3)
        image = np.stack([display_srgb(rgb, exposure) for _, rgb in strips])
        a.imshow(image, aspect="auto", extent=[opd[0], opd[-1], len(strips), 0])
        a.set_yticks(np.arange(len(strips)) + 0.5, [s for s, _ in strips], fontsize=7)
        a.set_title(title, fontsize=8, loc="left")
    np.atleast_1d(axes)[-1].set_xlabel("D (nm)")
    fig.savefig(out_png, dpi=80)
    plt.close(fig)
    return Path(out_png)


def pareto_plot(rows: list, out_png: Path) -> Path:
    """p99 ΔE00 against bake time (LUT variants) with approximation rows as lines."""
    plt = _pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    luts = [r for r in rows if r["kind"] == "lut"]
    for a, key, label in ((a1, "bake_seconds", "bake time (s)"), (a2, "bytes", "LUT size (bytes)")):
        x = np.array([r[key] for r in luts])
        y = np.array([r["de00_p99"] for r in luts])
        a.scatter(x, y, c="C0")
        for r in luts:
            a.annotate(r["name"], (r[key], r["de00_p99"]), fontsize=6, xytext=(3, 3), textcoords="offset points")
        front = _pareto_front(x, y)
        a.plot(x[front], y[front], "C0-", lw=1)
        for i, r in enumerate(r for r in rows if r["kind"] == "approximation"):
            a.axhline(r["de00_p99"], color=f"C{i + 1}", ls="--", lw=1, label=f"{r['name']} (no LUT)")
        a.set_xscale("log")
        a.set_yscale("log")
        a.set_xlabel(label)
        a.set_ylabel("p99 ΔE00")
        a.legend(fontsize=7)
    fig.savefig(out_png, dpi=80)
    plt.close(fig)
    return Path(out_png)


def _pareto_front(x, y):
    order = np.argsort(x, kind="stable")
    front, best = [], np.inf
    for i in order:
        if y[i] < best:
            front.append(i)
            best = y[i]
    return np.array(front, dtype=int)
