"""The spectral rule each texel of a bake needs, and the bound on its truncation where the rule is capped.

A texel's rule level on the spec's ladder (spectral.RuleLadder, lutbake/spectral/rules.py) follows from
two numbers of its film stack: the cycles its fringes make over the visible span, D·Re(Y2)/η2 times the
span in wavenumber, and the round trip's amplitude |r21·r23|, which sets how sharp they are. Where a
texel needs more than the ladder's cap, its truncation error is bounded (``truncation_estimate``) and
``capped_texels`` screens a whole grid for them in bounded memory. The spectral rules themselves know
nothing of grids; this module applies them to a BakeSpec's nodes, whose methods of the same names call it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.grid.texels import eta3_columns, node_values
from lutbake.physics.optics import normal_admittance, round_trip_amplitude
from lutbake.spectral.rules import WAVENUMBER_SPAN_PER_NM

if TYPE_CHECKING:
    from lutbake.grid.spec import BakeSpec

__all__ = ["cell_levels", "row_levels", "truncation_estimate", "capped_texels", "SCREEN_CHUNK"]

SCREEN_CHUNK = 1 << 16  # texels capped_texels screens at once


def fringes(
    spec: BakeSpec, cos_theta: npt.ArrayLike, opd_nm: npt.ArrayLike, eta3: npt.ArrayLike, kappa3: npt.ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """(cycles over the visible span, |r21·r23|) of each texel of ``spec``'s film."""
    g2 = normal_admittance(spec.eta2, 0.0, spec.eta1, cos_theta)
    cycles = np.asarray(opd_nm) * g2.real / spec.eta2 * WAVENUMBER_SPAN_PER_NM
    return cycles, round_trip_amplitude(spec.eta1, spec.eta2, eta3, kappa3, cos_theta)


def cell_levels(
    spec: BakeSpec, cos_theta: npt.ArrayLike, opd_nm: npt.ArrayLike, eta3: npt.ArrayLike, kappa3: npt.ArrayLike
) -> np.ndarray:
    """Spectral rule level of each texel (spectral.RuleLadder.level), float64 on the host."""
    return spec.ladder.level(*fringes(spec, cos_theta, opd_nm, eta3, kappa3))


def row_levels(spec: BakeSpec, y0: int, y1: int) -> np.ndarray:
    """Levels of every texel in rows [y0, y1), flat: equal to cell_levels on cell_params,
    but |r21·r23| is evaluated once per (x, κ3) and cycles once per (cos θ, D)."""
    width, _ = spec.image_size
    cos_t, opd, kappa3 = (node_values(spec, n) for n in ("cos_theta", "opd_nm", "kappa3"))
    i_cos, i_opd, _, k_index = spec.layout.nodes(np.arange(width), np.arange(y0, y1))
    kappa_rows = np.unique(k_index)
    rt = round_trip_amplitude(
        spec.eta1, spec.eta2, eta3_columns(spec)[None, :], kappa3[kappa_rows][:, i_cos], cos_t[i_cos][None, :]
    )
    rt_rows = rt[np.searchsorted(kappa_rows, k_index)]
    g2 = normal_admittance(spec.eta2, 0.0, spec.eta1, cos_t[i_cos]).real
    cycles = opd[i_opd][:, i_cos] * (g2 / spec.eta2 * WAVENUMBER_SPAN_PER_NM)[None, :]
    return spec.ladder.level(cycles, rt_rows).ravel()


def truncation_estimate(
    spec: BakeSpec, cos_theta: npt.ArrayLike, opd_nm: npt.ArrayLike, eta3: npt.ArrayLike, kappa3: npt.ArrayLike
) -> np.ndarray:
    """Bound on the spectral truncation error of texels past the ladder's cap (else 0). At grazing
    incidence (cos θ1 = 0) R ≡ 1 at every wavenumber, which any rule integrates exactly: 0 there."""
    bound = spec.ladder.truncation_estimate(*fringes(spec, cos_theta, opd_nm, eta3, kappa3))
    return np.where(np.asarray(cos_theta) > 0.0, bound, 0.0)


def capped_texels(
    spec: BakeSpec, limit: int = 64, keep: Callable[[tuple[np.ndarray, ...]], np.ndarray] | None = None
) -> tuple[int, float, tuple[np.ndarray, ...]]:
    """Texels of ``spec`` past the ladder's cap (of those for which ``keep(texels)`` is true, given it): (count,
    largest bound, the ``limit`` worst as (cos θ, D, η3, κ3) arrays).

    Cycles, hence the need for nodes and the bound, grow with D, so each
    (image column, κ3) pair is screened at its largest D first; screened and expanded a chunk at a
    time, so memory stays bounded (SCREEN_CHUNK texels) whatever the grid.
    """
    cos_nodes, opd, kappa_nodes = (node_values(spec, n) for n in ("cos_theta", "opd_nm", "kappa3"))
    width, (n_opd, n_kappa3) = spec.image_size[0], (opd.shape[0], kappa_nodes.shape[0])
    eta3_by_x = eta3_columns(spec)
    count, best, worst = 0, 0.0, tuple(np.empty(0) for _ in range(4))
    worst_bound = np.empty(0)
    for start in range(0, width * n_kappa3, SCREEN_CHUNK):
        column = np.arange(start, min(start + SCREEN_CHUNK, width * n_kappa3))  # x major, κ3 minor
        x = column // n_kappa3
        i_cos = np.asarray(spec.layout.nodes(x, 0)[0])  # an array, as x is
        cos_t, eta3, kappa3 = cos_nodes[i_cos], eta3_by_x[x], kappa_nodes[column % n_kappa3, i_cos]
        cols = np.flatnonzero(truncation_estimate(spec, cos_t, np.full(cos_t.shape, opd[-1, 0]), eta3, kappa3))
        step = max(1, SCREEN_CHUNK // n_opd)
        for c in range(0, cols.size, step):
            sub = cols[c : c + step]
            params = (
                np.repeat(cos_t[sub], n_opd),
                opd[:, i_cos[sub]].T.ravel(),
                np.repeat(eta3[sub], n_opd),
                np.repeat(kappa3[sub], n_opd),
            )
            bound = truncation_estimate(spec, *params)
            mask = bound > 0
            if keep is not None and mask.any():
                mask[mask] = keep(tuple(p[mask] for p in params))
            count += int(mask.sum())
            best = max(best, float(bound[mask].max(initial=0.0)))
            # the worst so far, in grid order among equals (a stable sort over what came first)
            worst_bound = np.concatenate([worst_bound, bound[mask]])
            worst = tuple(np.concatenate([w, p[mask]]) for w, p in zip(worst, params))
            keep_order = np.argsort(-worst_bound, kind="stable")[:limit]
            worst_bound, worst = worst_bound[keep_order], tuple(w[keep_order] for w in worst)
    return count, best, worst
