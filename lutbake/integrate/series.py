"""The series on the device: the host's inputs of kernels/airy.cl's Fourier series and poles.cl's closed
form for one spec (``series_chunks``), their buffers, the plan over the whole grid (``BakePlan``: which
texels each path takes, the largest bounds they enforce, the closed form's colours it kept, the (cos θ,
D) pairs' shared table), and the passes that integrate one band of rows (``SeriesOnDevice.enqueue_band``).

Each texel is summed as the exact Fourier series (lutbake/spectral/fourier.py) where its rule allows, by
the poles' closed form (lutbake/spectral/poles.py) where the film propagates and the series would be long,
and what both leave goes to the direct quadrature (lutbake/integrate/direct.py).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake.grid.memory import KEPT_COLOUR_BYTES, KEPT_TEXEL_BYTES, SERIES_CHUNK
from lutbake.integrate.program import DeviceProgram, signed_cos_theta2
from lutbake.spectral.fourier import (
    DEFAULT_SERIES_TOLERANCE,
    NU0_PER_NM,
    SERIES_BUDGET,
    series_coefficients,
    weight_transform,
)

if TYPE_CHECKING:
    import pyopencl

    from lutbake.grid.spec import BakeSpec
    from lutbake.spectral.fourier import SeriesCoefficients

__all__ = ["SeriesStats", "BakePlan", "SeriesOnDevice", "series_shapes", "series_chunks"]

PAIR_TABLE_BYTES = 48 << 20  # most memory the pairs' shared Ŵ(mX) take (more: each texel evaluates the table)
# Texels of a (cos θ, D) pair that share its Ŵ(mX) before a shared table pays (the table costs a pair
# its largest term count in evaluations; each texel then saves its own).
MIN_TEXELS_PER_PAIR = 8
CHUNK = SERIES_CHUNK  # columns or pairs per step of series_chunks: its temporaries stay bounded
COLUMN = 24  # REAL per column in the kernel's layout (COLUMN in airy.cl)


class SeriesStats:
    """The rule's outcome over a bake: texels per path (the series, the poles' closed form, the direct
    quadrature) and the largest a-priori bound each of the first two enforces."""

    def __init__(self, texels: Iterable[int] = (0, 0, 0), bounds: Iterable[float] = (0.0, 0.0)):
        self.texels = list(texels)
        self.bounds = list(bounds)
        self.shared_terms = 0  # Ŵ(mX) values the (cos θ, D) pairs share (0: the texels evaluate the table)

    def add(self, counts: npt.ArrayLike, bounds: npt.ArrayLike) -> None:
        """Fold in per-group counts (groups, 3) and largest bounds (groups, 2)."""
        self.texels = [t + int(c) for t, c in zip(self.texels, np.asarray(counts).sum(axis=0))]
        self.bounds = [max(b, float(m)) for b, m in zip(self.bounds, np.asarray(bounds).max(axis=0, initial=0.0))]

    series_texels = property(lambda self: self.texels[0])
    closed_form_texels = property(lambda self: self.texels[1])
    direct_texels = property(lambda self: self.texels[2])

    def describe(self) -> dict:
        return {
            "series_texels": self.texels[0],
            "closed_form_texels": self.texels[1],
            "direct_texels": self.texels[2],
            "series_bound_rgb_max": self.bounds[0],
            "closed_form_bound_rgb_max": self.bounds[1],
        }


class KeptColours:
    """The plan's closed form kept for the bake, over the whole image (texel index y·width + x, ascending):
    the closed form's texels and their RGB, and the direct quadrature's texels. Filled band by band while
    it fits KEPT_COLOUR_BYTES (``add`` returns False once it would not: the bake then integrates again)."""

    def __init__(self) -> None:
        self.bytes = 0
        self._parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def add(self, first_texel: int, texels: np.ndarray, path: np.ndarray, rgb: np.ndarray) -> bool:
        """Keep a band's list (band indices ``texels`` from image texel ``first_texel``, their ``path``
        and ``rgb``); False (keeping nothing more) where it would pass KEPT_COLOUR_BYTES."""
        closed = path == 1
        self.bytes += KEPT_TEXEL_BYTES["closed"] * int(closed.sum()) + KEPT_TEXEL_BYTES["direct"] * int((~closed).sum())
        if self.bytes > KEPT_COLOUR_BYTES:
            self._parts = []
            return False
        order = np.argsort(texels)
        index, closed, rgb = texels[order] + np.int64(first_texel), closed[order], rgb[order]
        self._parts.append((index[closed], rgb[closed], index[~closed]))
        return True

    def whole(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(closed-form texels, their RGB (n, 3), direct texels) over the image."""
        parts = list(zip(*self._parts)) or [[np.zeros(0, np.int64)], [np.zeros((0, 3))], [np.zeros(0, np.int64)]]
        return np.concatenate(parts[0]), np.concatenate(parts[1]), np.concatenate(parts[2])


class BakePlan:
    """A spec's rule outcome on one device: stats, the texels the series leaves in each image row
    (``rest_per_row``), the closed form's colours and the direct texels (``kept``: KeptColours.whole, or
    None where they did not fit), and, when the pairs' Ŵ(mX) fit PAIR_TABLE_BYTES and enough texels share
    each pair, their running term offsets (else None: texels evaluate the table)."""

    def __init__(
        self,
        stats: SeriesStats,
        pair_terms: np.ndarray,
        texels_per_pair: int,
        rest_per_row: np.ndarray,
        kept: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
    ):
        self.stats = stats
        self.rest_per_row = rest_per_row
        self.kept = kept
        offsets = np.concatenate([[0], np.cumsum(pair_terms, dtype=np.int64)])
        fits = offsets[-1] * 48 <= PAIR_TABLE_BYTES
        self.offsets = offsets.astype(np.int32) if fits and texels_per_pair >= MIN_TEXELS_PER_PAIR else None
        stats.shared_terms = int(offsets[-1]) if self.offsets is not None else 0
        self.buffers: list[pyopencl.Buffer] | None = None  # the shared table on the device, once made


def series_shapes(spec: BakeSpec) -> tuple[tuple[int, int], tuple[int, int]]:
    """Shapes of the series kernels' two inputs (series_chunks): coefficients, film."""
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    return (n_kappa3 * n_eta3 * n_cos, COLUMN), (n_opd * n_cos, 3)


def series_chunks(spec: BakeSpec, dtype: npt.DTypeLike = np.float64) -> Iterator[tuple[int, int, np.ndarray]]:
    """Host inputs of kernels/airy.cl's series in the kernel's layout, as ``dtype``, a chunk of rows at a
    time, so that neither they nor their temporaries scale with the grid on the host: yields (input,
    first row, rows) with input 0 the coefficients, 1 the film (shapes: series_shapes).

    coefficients (κ3, η3, cos θ, COLUMN): [s, p] × [C0, K, q, 1 − |q|] (1 − |q| = −1 marking an
    evanescent film), then the column's rule constants (_column_rule), then zeros; film (D, cos θ,
    [X, e^{i2πXν0}]).
    """
    cos_t, opd, kappa3 = (spec.node_values(n) for n in ("cos_theta", "opd_nm", "kappa3"))
    n_cos, n_opd, n_eta3, n_kappa3 = spec.shape
    eta3 = spec.eta3_columns()  # (η3, cos θ) flattened
    wt = weight_transform(spec.observer, spec.space)
    (n_columns, _), (n_pairs, _) = series_shapes(spec)
    for start in range(0, n_columns, CHUNK):
        flat = np.arange(start, min(start + CHUNK, n_columns))
        column, i_kappa3 = flat % (n_eta3 * n_cos), flat // (n_eta3 * n_cos)
        co = series_coefficients(
            spec.eta1, spec.eta2, cos_t[column % n_cos], 0.0, eta3[column], kappa3[i_kappa3, column % n_cos]
        )
        one_minus_q = np.where(co.in_scope, co.one_minus_q, -1.0)
        block = np.zeros((flat.size, COLUMN), dtype)
        for p in (0, 1):
            block[:, 6 * p : 6 * p + 6] = np.stack(
                [co.c0[p], co.k[p].real, co.k[p].imag, co.q[p].real, co.q[p].imag, one_minus_q[p]], -1
            )
        block[:, 12:21] = _column_rule(co, wt.mass.max())
        yield 0, start, block
    cos2 = signed_cos_theta2(spec.eta1, spec.eta2, cos_t).clip(0)
    for start in range(0, n_pairs, CHUNK):
        flat = np.arange(start, min(start + CHUNK, n_pairs))
        x_nm = opd[flat // n_cos, flat % n_cos] * cos2[flat % n_cos]
        turn = np.exp(2j * np.pi * NU0_PER_NM * x_nm)
        yield 1, start, np.stack([x_nm, turn.real, turn.imag], -1).astype(dtype)


def _column_rule(co: SeriesCoefficients, mass: float) -> np.ndarray:
    """(n, 9): the rule's constants of each column, float64: |K|/(1 − |q|) (0 where K = 0), |q|, log |q|,
    |K| per polarization (s, p), then the terms after which (Σ_pol |K|/(1 − |q|)) max|q|^m · mass ≤ tol
    (a bound on the series' terms: sup |Ŵ| ≤ mass), +1 for the rounding of the logs."""
    k_abs, q_abs = np.abs(co.k), np.abs(co.q)
    with np.errstate(divide="ignore", invalid="ignore"):
        lead = np.where(k_abs == 0, 0.0, k_abs / co.one_minus_q)
        log_q = np.log(q_abs)
        total = lead.sum(axis=0) * mass
        geometric = np.ceil(np.log(DEFAULT_SERIES_TOLERANCE / total) / np.log(q_abs.max(axis=0))) + 1
    geometric = np.where(total <= DEFAULT_SERIES_TOLERANCE, 0.0, np.where(q_abs.max(axis=0) == 0, 1.0, geometric))
    geometric = np.nan_to_num(geometric, nan=SERIES_BUDGET, posinf=SERIES_BUDGET)  # evanescent: never used
    return np.stack([*lead, *q_abs, *np.nan_to_num(log_q, nan=0.0, neginf=-1e300), *k_abs, geometric], -1)


class SeriesOnDevice:
    """The series kernels' inputs for one spec on one device (uploaded chunk by chunk: the host never
    holds them whole), the spec's plan (made on first use), and its bands' passes."""

    def __init__(self, program: DeviceProgram, spec: BakeSpec):
        self.program, self.spec = program, spec
        self._plan: BakePlan | None = None
        real = program.dtype
        size = np.dtype(real).itemsize
        inputs = [program.scratch(rows * width * size, "r") for rows, width in series_shapes(spec)]
        for which, start, block in series_chunks(spec, real):
            program.write(inputs[which], block, start * block.shape[1] * size)
        wt = weight_transform(spec.observer, spec.space)
        key = ("fourier", spec.observer, spec.space)
        if key not in program.tables:
            table = np.stack([wt.coefficients.real, wt.coefficients.imag], -1)  # (intervals, 3, 6, 2)
            tail = np.array([wt.mass.max(), wt.edge.max(), wt.variation.max()])
            program.tables[key] = [program.input(table), program.input(tail)]
        table, tail = program.tables[key]
        self._film, self._transform = inputs[1], [table, np.int32(wt.coefficients.shape[0]), real(wt.step_nm)]
        self._inputs = [
            *inputs,
            *self._transform,
            tail,
            real(wt.interpolation_bound.max()),
            real(DEFAULT_SERIES_TOLERANCE),
            np.int32(SERIES_BUDGET),
        ]

    def _band_args(self, y0: int) -> list:
        n_cos, n_opd, _, _ = self.spec.shape
        return [np.int32(n_cos), np.int32(n_opd), np.int32(self.spec.image_size[0]), np.int32(y0), *self._inputs]

    def _cauchy(self) -> list:
        """The closed form's tables (lutbake/spectral/poles.py) for the spec's colour weights (uploaded once
        per observer and space)."""
        from lutbake.spectral.poles import cauchy_table, chebyshev_rule

        program, key = self.program, ("cauchy", self.spec.observer, self.spec.space)
        if key not in program.tables:
            table, rule = cauchy_table(*key[1:]), chebyshev_rule(*key[1:])
            arrays = [np.stack([t.real, t.imag], -1) for t in (table.shallow, table.deep)]
            arrays += [
                np.concatenate([table.knot_a, table.knot_b]),
                np.concatenate([rule.wavelength_nm[None], rule.weights]),
            ]
            real = program.dtype
            program.tables[key] = [*map(program.input, arrays), real(table.bound.max()), real(rule.mass.max())]
        return program.tables[key]

    def plan(self) -> BakePlan:
        """The rule over the whole grid (plan_rows, band by band): its outcome and each (cos θ, D) pair's
        series terms; the pairs' Ŵ(mX) when they fit one table (made once)."""
        if self._plan is None:
            stats = SeriesStats()
            n_cos, n_opd, n_eta3, n_kappa3 = self.spec.shape
            pair_terms = np.zeros(n_cos * n_opd, np.int32)
            rest_per_row = np.zeros(self.spec.image_size[1], np.int64)
            terms, kept = self.program.zeros(pair_terms.size), KeptColours()
            keeping = True
            for y0, y1 in self.spec.row_chunks():
                counts, bounds, keeping = self._plan_band(y0, y1, terms, rest_per_row, kept if keeping else None)
                stats.add(counts, bounds)
            self.program.read(pair_terms, terms)
            self._plan = BakePlan(stats, pair_terms, n_eta3 * n_kappa3, rest_per_row, kept.whole() if keeping else None)
        return self._plan

    def _plan_band(
        self, y0: int, y1: int, terms: pyopencl.Buffer, rest_per_row: np.ndarray, kept: KeptColours | None
    ) -> tuple[list[list[int]], list[list[float]], bool]:
        """The rule over rows [y0, y1): ([[series, closed-form, direct texels]], [[their largest bounds]],
        whether ``kept`` (None: keeping nothing) took the band's closed-form colours and direct texels), the
        pairs' term counts raised in ``terms``, the texels the series leaves counted in ``rest_per_row``."""
        program, kernels = self.program, self.program.kernels
        width = self.spec.image_size[0]
        cells = (y1 - y0) * width
        rest, rest_count = program.scratch(max(1, cells) * 4), program.zeros()
        bounds = program.scratch(max(1, cells) * np.dtype(program.dtype).itemsize)
        program.run(kernels.plan_rows, cells, *self._band_args(y0), terms, rest, rest_count, bounds)
        left, series_bound = program.count(rest_count), program.largest(bounds, cells)
        if not left:
            return [[cells, 0, 0]], [[series_bound, 0.0]], kept is not None
        rest_texels = np.empty(left, np.int32)
        program.read(rest_texels, rest)
        rest_per_row[y0:y1] += np.bincount(rest_texels // width, minlength=y1 - y0)
        path, bound, rgb = np.empty(left, np.int8), np.empty(left, program.dtype), np.empty((left, 3), program.dtype)
        path_buf, bound_buf, rgb_buf = (program.scratch(a.nbytes, "w") for a in (path, bound, rgb))
        args = [*self._band_args(y0), *self._cauchy(), rest, rest_count, np.int32(kept is not None)]
        program.run(kernels.plan_texels_closed, left, *args, path_buf, bound_buf, rgb_buf)
        program.read(path, path_buf)
        program.read(bound, bound_buf)
        if kept is not None:
            program.read(rgb, rgb_buf)
        keeping = kept is not None and kept.add(y0 * width, rest_texels, path, rgb)
        closed, direct = np.bincount(path, minlength=3)[1:3]
        return [[cells - left, closed, direct]], [[series_bound, float(bound[path == 1].max(initial=0.0))]], keeping

    def _pair_table(self, plan: BakePlan, pair_offsets: np.ndarray) -> list[pyopencl.Buffer]:
        """The pairs' shared Ŵ(mX) for bake_rows_series (pair_transform, once per spec), given the plan's
        ``pair_offsets`` (its offsets, when the pairs share a table): [offsets, values]."""
        if plan.buffers is None:
            program = self.program
            offsets = program.input(pair_offsets, np.int32)
            table = program.scratch(max(1, 6 * int(pair_offsets[-1])) * np.dtype(program.dtype).itemsize)
            program.run(
                program.kernels.pair_transform, pair_offsets.size - 1, self._film, offsets, *self._transform, table
            )
            plan.buffers = [offsets, table]
        return plan.buffers

    def enqueue_band(self, y0: int, y1: int, out: pyopencl.Buffer) -> tuple[list[object], np.ndarray | None]:
        """Enqueue the series on rows [y0, y1) into ``out``, then the closed form at what it leaves: (the
        buffers to keep until they are done, the band's texels left for the direct quadrature, sorted, or
        None where the plan expects none). Where the plan kept its closed form's colours (BakePlan.kept) they
        are put in place (_kept_band): the plan searched those poles already. Else the closed form runs
        over as many work-items as the plan counts texels left in these rows: launched over the whole band,
        its few busy work-groups came first and PoCL's scheduler gave them all to one thread. The band's own
        counts are among the buffers kept, as (count, event, planned), for PendingRows to check against the
        plan."""
        program, kernels, plan = self.program, self.program.kernels, self.plan()
        width = self.spec.image_size[0]
        cells = (y1 - y0) * width
        lists, counts = [program.scratch(max(1, cells) * 4)], [program.zeros()]
        band = _band_of(plan.kept, y0 * width, y1 * width) if plan.kept is not None else None
        mask = program.input(_left_mask(band, cells), np.int8) if band is not None else counts[0]  # unread if None
        rule: list = [mask, np.int32(band is not None), out, lists[0], counts[0]]
        if plan.offsets is not None:
            program.run(
                kernels.bake_rows_series, cells, *self._band_args(y0), *self._pair_table(plan, plan.offsets), *rule
            )
        else:
            program.run(kernels.bake_rows_series_table, cells, *self._band_args(y0), *rule)
        planned = int(plan.rest_per_row[y0:y1].sum())
        if band is not None:
            return self._kept_band(band, out, [*lists, *counts, mask, _checked(program, counts[0], planned)])
        lists.append(program.scratch(max(1, cells) * 4))
        counts.append(program.zeros())
        if planned:
            args = [*self._band_args(y0), *self._cauchy(), lists[0], counts[0], out, lists[1], counts[1]]
            program.run(kernels.bake_texels_closed, planned, *args)
        keep: list[object] = [*lists, *counts, _checked(program, counts[0], planned)]
        left = program.count(counts[1]) if plan.stats.direct_texels else 0
        if left:
            texels = np.empty(left, np.int32)
            program.read(texels, lists[1])
            return keep, np.sort(texels)
        return keep + [_checked(program, counts[1], 0)], None  # the plan said none: the band must agree

    def _kept_band(
        self, band: tuple[np.ndarray, np.ndarray, np.ndarray], out: pyopencl.Buffer, keep: list
    ) -> tuple[list[object], np.ndarray | None]:
        """enqueue_band's second pass where the plan kept its closed form: the band's kept colours (``band``:
        _band_of) put into ``out`` (scatter_rgb), and its direct texels as the plan listed them."""
        program = self.program
        closed, rgb, direct = band
        if closed.size:
            texels, colours = program.input(closed, np.int32), program.input(rgb)
            program.run(program.kernels.scatter_rgb, closed.size, texels, colours, out)
            keep += [texels, colours]
        return keep, direct if direct.size else None


def _band_of(
    kept: tuple[np.ndarray, np.ndarray, np.ndarray], first: int, end: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plan's kept lists (KeptColours.whole) for image texels [first, end): (closed-form texels, their
    RGB, direct texels), texels as band indices (int32)."""
    closed, rgb, direct = kept
    (c0, c1), (d0, d1) = (np.searchsorted(index, [first, end]) for index in (closed, direct))
    return (closed[c0:c1] - first).astype(np.int32), rgb[c0:c1], (direct[d0:d1] - first).astype(np.int32)


def _left_mask(band: tuple[np.ndarray, np.ndarray, np.ndarray], cells: int) -> np.ndarray:
    """1 at each of a band's ``cells`` texels that the plan left to the closed form or the direct quadrature
    (``band``: _band_of), else 0: the series kernels' ``left``."""
    left = np.zeros(max(1, cells), np.int8)
    left[band[0]] = 1
    left[band[2]] = 1
    return left


def _checked(program: DeviceProgram, counter: pyopencl.Buffer, planned: int) -> tuple[np.ndarray, object, int]:
    """(count, the event of its copy, ``planned``): a band's counter read back without waiting, for
    PendingRows to hold against what the plan counted (the same rule ran on the same texels)."""
    count = np.zeros(1, np.int32)
    return count, program.read(count, counter, blocking=False), planned
