"""The exact runtime mode: the Fourier series of lutbake/spectral/fourier.py evaluated per pixel in a shader.

An engine that carries the film's (cos θ, d, η1, η2) and the base's η3 + iκ3
per pixel can skip the 4D LUT and sum the series itself (docs/spectral.md)::

    RGB_c = ½ Σ_pol [C0 Ŵ_c(0) + 2 Re Σ_{m≥1} K q^{m−1} Ŵ_c(m X)],   X = 2 η2 d cos θ2.

All it needs is Ŵ_c, the Fourier transform of the colour weights: a 1D complex
table per channel. ``write_exact_table`` writes it as an EXR (demodulated by
e^{i2πν0x} so it is smooth; real parts in the top half of the image, imaginary
parts in the bottom half, row-major, 2048 texels a row) built from
``fourier.weight_transform`` — exactly the weights the ground truth
integrates — plus GLSL/HLSL includes with ``lutbake_exact`` (one base index)
and ``lutbake_exact_rgb`` (per-channel n, k). The includes interpolate the
table linearly between texel centres (texelFetch: no dependence on the
hardware's filtering precision) and stop the sum with the bake kernel's rule:
after M terms, when Σ_pol |K| |q|^M/(1 − |q|) · sup_{x ≥ (M+1)X} |Ŵ| ≤ tolerance,
or at the term cap, or where (M+1)X passes the table's end.

``exact_colour`` is the float64 numpy evaluation of the same math on a table
as stored (tests compare the shader with it, and it with the ground truth).
docs/lut-format.md specifies the file; lutbake/tables/ writes, reads and checks it
(its header's schema: tables/headers.py) and renders its includes (tables/includes.py).
"""

from __future__ import annotations

import functools
import hashlib
import json
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from lutbake import __version__
from lutbake.errors import ParameterError
from lutbake.spectral.fourier import (
    NU0_PER_NM,
    NU_HALF_BAND_PER_NM,
    SeriesCoefficients,
    series_coefficients,
    weight_transform,
)
from lutbake.tables.headers import EXACT_FORMAT, EXACT_FORMAT_VERSION
from lutbake.tables.lutfile import read_lut, write_table_set

if TYPE_CHECKING:
    from lutbake.physics.points import FilmPoints

__all__ = [
    "TABLE_STEP_NM",
    "TABLE_TEXELS",
    "TABLE_WIDTH",
    "DEFAULT_TOLERANCE",
    "DEFAULT_MAX_TERMS",
    "ExactTable",
    "ExactResult",
    "table_samples",
    "write_exact_table",
    "read_exact_table",
    "exact_colour",
    "RGB_WAVELENGTHS_NM",
    "METALS",
    "base_rgb",
]

TABLE_STEP_NM = 2.0  # linear interpolation error of Ŵ ≤ 3.3e-6 at this step (measured; bound in the header)
TABLE_TEXELS = 32768  # x from 0 to 65,534 nm: 64 terms of the thickest KHR film at normal incidence
TABLE_WIDTH = 2048  # WebGL2 and OpenGL ES 3.0 guarantee textures this wide
DEFAULT_TOLERANCE = 1e-4  # |ΔRGB| the truncation rule allows
DEFAULT_MAX_TERMS = 64  # the shader's loop cap (a #define the engine may change)
# Per-channel base indices for lutbake_exact_rgb: a named material's n, k at the dominant wavelengths
# of the Rec.709 primaries (docs/engines.md measures what this costs against the dispersive truth).
RGB_WAVELENGTHS_NM = (611.0, 549.0, 464.0)
METALS = {"Au": "Au", "Ag": "Ag", "Al": "Al", "Cu": "Cu", "Fe": "Fe", "Cr": "main/Cr/Johnson"}


@dataclass(frozen=True)
class ExactTable:
    """A Ŵ table as stored: ``samples`` (3, texels) complex, demodulated, at x = i·step."""

    meta: dict
    samples: np.ndarray

    @property
    def step_nm(self) -> float:
        return self.meta["table"]["step_nm"]

    @property
    def x_max_nm(self) -> float:
        return self.step_nm * (self.samples.shape[1] - 1)

    def tail_bound(self, x_nm: npt.ArrayLike) -> np.ndarray:
        """The include's bound on sup_{y ≥ x} |Ŵ_c(y)| (one for all channels)."""
        tail = self.meta["tail"]
        x = 2.0 * np.pi * np.asarray(x_nm, float)
        with np.errstate(divide="ignore"):
            return np.minimum(tail["mass"], (tail["edge"] + tail["variation"] / x) / x)

    def demodulated(self, x_nm: npt.ArrayLike) -> np.ndarray:
        """Linear interpolation between texels, (3, *x.shape), as the include does it."""
        s = np.asarray(x_nm, float) / self.step_nm
        i = np.minimum(np.floor(s).astype(np.int64), self.samples.shape[1] - 2)
        t = s - i
        return self.samples[:, i] * (1.0 - t) + self.samples[:, i + 1] * t


@dataclass
class ExactResult:
    values: np.ndarray  # (n, 3) linear RGB
    terms: np.ndarray  # (n,) terms taken
    bound: np.ndarray  # (n,) the rule's remainder bound where it stopped (> tolerance: capped or past the table)


def base_rgb(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(η3, κ3), each (3,), of a named material at RGB_WAVELENGTHS_NM."""
    from lutbake.physics.materials import material

    eta, kappa = material(METALS.get(name, name)).index(np.array(RGB_WAVELENGTHS_NM))
    return np.asarray(eta, float), np.asarray(kappa, float)


def table_samples(observer: str = "cie1931", space: str = "rec709") -> np.ndarray:
    """Demodulated Ŵ_c(x) e^{−i2πν0x} at x = i·TABLE_STEP_NM, (3, TABLE_TEXELS) complex, float64."""
    wt = weight_transform(observer, space)
    x = TABLE_STEP_NM * np.arange(TABLE_TEXELS)
    return wt(x) * np.exp(-2j * np.pi * NU0_PER_NM * x)[None]


def _pack(samples: np.ndarray) -> np.ndarray:
    """(2·rows, TABLE_WIDTH, 3) image: real parts in the top rows, imaginary parts below."""
    rows = samples.shape[1] // TABLE_WIDTH
    re = samples.real.T.reshape(rows, TABLE_WIDTH, 3)
    im = samples.imag.T.reshape(rows, TABLE_WIDTH, 3)
    return np.concatenate([re, im])


def _unpack(image: np.ndarray) -> np.ndarray:
    rows = image.shape[0] // 2
    flat = np.asarray(image, float).reshape(2, rows * image.shape[1], 3)
    return (flat[0] + 1j * flat[1]).T


def _interpolation_bound(mass: np.ndarray) -> float:
    """A priori sup |lerp − f| of the band-limited f (|ν − ν0| ≤ ν_half): h²/8 · (2πν_half)² · mass."""
    return float(TABLE_STEP_NM**2 / 8.0 * (2.0 * np.pi * NU_HALF_BAND_PER_NM) ** 2 * mass.max())


def table_metadata(
    observer: str, space: str, precision: str, exact: np.ndarray, stored: np.ndarray, tolerance: float, max_terms: int
) -> dict:
    """The header: ``exact`` the float64 samples, ``stored`` the image as written."""
    wt = weight_transform(observer, space)
    digest = hashlib.sha256(
        json.dumps(
            [__version__, observer, space, precision, TABLE_STEP_NM, TABLE_TEXELS, repr(tolerance), max_terms]
        ).encode()
    )
    return {
        "format": EXACT_FORMAT,
        "format_version": EXACT_FORMAT_VERSION,
        "lutbake_version": __version__,
        "content_hash": digest.hexdigest()[:16],
        "observer": observer,
        "illuminant": "D65" if space != "acescg" else "ACES white (CIE daylight series)",
        "space": space,
        "encoding": "linear",
        "precision": precision,
        "channels": ["R", "G", "B"],
        "table": {
            "quantity": "demodulated colour-weight transform W_c(x) exp(-2 pi i nu0 x)",
            "step_nm": TABLE_STEP_NM,
            "texels": TABLE_TEXELS,
            "width": TABLE_WIDTH,
            "rows_per_part": TABLE_TEXELS // TABLE_WIDTH,
            "x_max_nm": TABLE_STEP_NM * (TABLE_TEXELS - 1),
            "nu0_per_nm": NU0_PER_NM,
            "layout": "real parts in scanlines [0, rows), imaginary parts in "
            "[rows, 2 rows); texel i at (i mod width, i div width)",
            "interpolation": "linear",
        },
        # sup_{y ≥ x} |Ŵ_c(y)| ≤ min(mass, (edge + variation/(2πx))/(2πx)), largest channel's constants
        "tail": {"mass": float(wt.mass.max()), "edge": float(wt.edge.max()), "variation": float(wt.variation.max())},
        "error": {
            "interpolation_bound": _interpolation_bound(wt.mass),
            "transform_bound": float(wt.interpolation_bound.max()),
            "storage_max": float(np.abs(_unpack(stored) - exact).max()),
        },
        "include": {"tolerance": tolerance, "max_terms": max_terms},
    }


def write_exact_table(
    out_path: str | PathLike[str],
    observer: str = "cie1931",
    space: str = "rec709",
    precision: str = "float",
    tolerance: float = DEFAULT_TOLERANCE,
    max_terms: int = DEFAULT_MAX_TERMS,
) -> dict:
    """Write NAME.exr, NAME.json, NAME.glsl and NAME.hlsl as one set; return the metadata."""
    from lutbake.lut.bake import _check_writable

    out_path = Path(out_path)
    if not (0 < tolerance < 1):
        raise ParameterError("{tolerance} {value} must lie in (0, 1)", value=f"{tolerance:g}")
    if not (1 <= max_terms <= 4096):
        raise ParameterError("{max_terms} {value} must lie in [1, 4096]", value=max_terms)
    _check_writable(out_path)
    meta, stored = _stored(observer, space, precision, tolerance, max_terms)
    write_table_set(out_path, stored, meta, precision)
    return meta


def _stored(
    observer: str,
    space: str,
    precision: str,
    tolerance: float = DEFAULT_TOLERANCE,
    max_terms: int = DEFAULT_MAX_TERMS,
) -> tuple[dict, np.ndarray]:
    """(header, image as stored) of the table `exact-table` writes."""
    exact = table_samples(observer, space)
    stored = _pack(exact).astype(np.float16 if precision == "half" else np.float32)
    return table_metadata(observer, space, precision, exact, stored, tolerance, max_terms), stored


@functools.lru_cache(maxsize=4)
def stored_table(observer: str = "cie1931", space: str = "rec709", precision: str = "float") -> ExactTable:
    """The default table as an engine reads it back from `exact-table`'s file, without the file."""
    meta, stored = _stored(observer, space, precision)
    return ExactTable(meta, _unpack(stored))


def exact_mode(stack: FilmPoints, space: str = "rec709", observer: str = "cie1931") -> ExactResult:
    """The exact runtime mode (the default float table and include settings) at film stacks of one
    constant film η1 | η2 and constant bases, taken as the approximations are: what `report` and
    `sweep` score beside a LUT."""
    eta1, eta2 = float(np.ravel(stack.eta1)[0]), float(np.ravel(stack.eta2)[0])
    stack.require("exact mode", film=None, base=None, eta1=eta1, eta2=eta2)
    cos_theta, thickness, eta3, kappa3 = (
        np.ravel(a) for a in np.broadcast_arrays(stack.cos_theta, stack.thickness_nm, stack.eta3, stack.kappa3)
    )
    return exact_colour(stored_table(observer, space), cos_theta, thickness, eta1, eta2, eta3, kappa3)


def exact_mode_rgb(stack: FilmPoints, space: str = "rec709", observer: str = "cie1931") -> np.ndarray:
    """``exact_mode``'s linear RGB (n, 3)."""
    return exact_mode(stack, space, observer).values


def read_exact_table(path: str | PathLike[str]) -> ExactTable:
    """The table as stored, validated (ValueError names the file and the field)."""
    meta, image = read_lut(path, formats=(EXACT_FORMAT,))
    return ExactTable(meta, _unpack(image))


def _channel_coefficients(
    eta1: float,
    eta2: float,
    cos_theta: npt.ArrayLike,
    opd_nm: npt.ArrayLike,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
) -> SeriesCoefficients:
    """Series constants per channel: arrays (2, n, 3). eta3/kappa3 of shape (n,) or (n, 3) (per channel)."""
    n = np.size(cos_theta)
    eta3 = np.broadcast_to(np.asarray(eta3, float).reshape(n, -1), (n, 3))
    kappa3 = np.broadcast_to(np.asarray(kappa3, float).reshape(n, -1), (n, 3))
    parts = [series_coefficients(eta1, eta2, cos_theta, opd_nm, eta3[:, c], kappa3[:, c]) for c in range(3)]
    stack = {key: np.stack([getattr(p, key) for p in parts], axis=-1) for key in ("c0", "k", "q", "one_minus_q")}
    co = SeriesCoefficients(**stack, x_nm=parts[0].x_nm, in_scope=parts[0].in_scope)
    return _grazing_on_a_matched_film(co, (np.asarray(cos_theta) == 0) & (eta2 == eta1))


def _grazing_on_a_matched_film(co: SeriesCoefficients, at: np.ndarray) -> SeriesCoefficients:
    """At cos θ1 = 0 on a film matching the ambient (η2 = η1: Y1 = Y2 = 0, where a is 0/0) r12 = −1, the
    ground truth's value at every grazing angle (physics/optics.py), so C0 = 1 and K = 0: R = Ŵ(0), white,
    as the include's a = −1 gives. series_coefficients leaves the point out of scope (g2 = 0: no propagating
    film); it is the domain's edge, η2 = η1 sin θ1 at θ1 = 90°."""
    edge = at[None, :, None]
    return SeriesCoefficients(
        c0=np.where(edge, 1.0, co.c0),
        k=np.where(edge, 0.0, co.k),
        q=np.where(edge, 0.0, co.q),
        one_minus_q=np.where(edge, 1.0, co.one_minus_q),
        x_nm=np.where(at, 0.0, co.x_nm),
        in_scope=co.in_scope | at,
    )


def exact_colour(
    table: ExactTable,
    cos_theta: npt.ArrayLike,
    thickness_nm: npt.ArrayLike,
    eta1: float,
    eta2: float,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
    tolerance: float | None = None,
    max_terms: int | None = None,
) -> ExactResult:
    """RGB by the include's math in float64: η1, η2 scalars; the rest arrays (n,); η3, κ3 (n,) or (n, 3).

    The film must propagate (η2 > η1 sin θ1, always so for a film in air), or be the ambient's index at
    grazing incidence (η2 = η1, cos θ1 = 0: white, the ground truth's r12 = −1)."""
    tolerance = table.meta["include"]["tolerance"] if tolerance is None else tolerance
    max_terms = table.meta["include"]["max_terms"] if max_terms is None else max_terms
    cos_theta = np.atleast_1d(np.asarray(cos_theta, float))
    opd = 2.0 * eta2 * np.broadcast_to(np.asarray(thickness_nm, float), cos_theta.shape)
    co = _channel_coefficients(eta1, eta2, cos_theta, opd, eta3, kappa3)
    if not co.in_scope.all():
        raise ValueError("exact mode needs a propagating film (eta2 > eta1 sin theta1, or eta2 = eta1)")
    x = co.x_nm
    w0 = table.samples[:, 0].real
    phase = np.exp(2j * np.pi * NU0_PER_NM * x)[None, :, None]
    power, ratio = co.k * phase, co.q * phase  # K e^{iθ} (q e^{iθ})^{m−1}: Ŵ(mX) = f(mX) e^{iθm}
    with np.errstate(divide="ignore", invalid="ignore"):
        geometric = np.where(co.k == 0, 0.0, np.abs(co.k) / co.one_minus_q)
        closed = np.where(co.k == 0, 0.0, co.k / (1.0 - co.q))
    acc = np.where(x[None, :, None] == 0, closed * w0, 0.0)  # X = 0: Σ K q^{m−1} = K/(1 − q)
    terms = np.zeros(x.size, np.int64)
    bound = np.zeros(x.size)
    active = x > 0
    for m in range(1, max_terms + 2):
        remainder = geometric.sum(axis=0).max(axis=-1) * table.tail_bound(m * x)
        bound = np.where(active, remainder, bound)
        active &= (remainder > tolerance) & (m * x <= table.x_max_nm) & (m <= max_terms)
        if not active.any():
            break
        f = table.demodulated(np.where(active, m * x, 0.0)).T  # (n, 3)
        acc = acc + np.where(active[None, :, None], (power * f[None]).real, 0.0)
        power = power * ratio
        geometric = geometric * np.abs(co.q)
        terms += active
    capped = (terms == max_terms) & (x > 0)
    if capped.any():
        acc = acc + np.where(capped[None, :, None], _resummed_tail(table, x, terms, co, power), 0.0)
    values = 0.5 * (co.c0 * w0 + 2.0 * acc.real).sum(axis=0)
    return ExactResult(values, terms, np.where(x > 0, bound, 0.0))


def _resummed_tail(
    table: ExactTable, x: np.ndarray, terms: np.ndarray, co: SeriesCoefficients, power: np.ndarray
) -> np.ndarray:
    """Re of the terms past the cap, K e^{iθ} z^M Σ_{j≥0} z^j A(x_M + jX) (x_M = (M+1)X, z = q e^{iθ}),
    in closed form where that is the smaller error: (2, n, 3).

    Near grazing incidence over a base matching the ambient, |q| → 1 and X → 0 together, and the series
    needs ~1/(1 − |q|) terms. There A (demodulated, band-limited to |ν − ν0| ≤ ν_half) barely moves over
    the tail's reach, so its quadratic Taylor polynomial at x_M (from the three table nodes nearest x_M)
    sums against z^j exactly: Σ z^j = 1/ζ, Σ j z^j = z/ζ², Σ j² z^j = z(1 + z)/ζ³, ζ = 1 − z. Its error
    is ~ mass·ρ³/|ζ| per unit |K|, ρ = 2π ν_half X/|ζ|; dropping the tail errs by up to
    tail_bound(x_M)/(1 − |q|): the tail is added where the first is smaller (per polarization and channel).
    ζ = (1 − q) − q(e^{iθ} − 1), the form the include computes without cancellation."""
    theta = 2.0 * np.pi * NU0_PER_NM * x
    em1 = (-2.0 * np.sin(0.5 * theta) ** 2 + 1j * np.sin(theta))[None, :, None]  # e^{iθ} − 1
    z = co.q * (1.0 + em1)
    zeta = (1.0 - co.q) - co.q * em1
    x_m = (terms + 1) * x
    h = table.step_nm
    node = np.clip(np.floor(x_m / h + 0.5).astype(np.int64), 1, table.samples.shape[1] - 2)
    below, at, above = (table.samples[:, node + i].T[None] for i in (-1, 0, 1))
    d1, d2 = (above - below) / (2.0 * h), (above - 2.0 * at + below) / h**2  # A', A'' at the node
    off = (x_m - h * node)[None, :, None]  # x_M − node
    step = x[None, :, None]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # ζ = 0 only where K = 0
        s0, s1, s2 = 1.0 / zeta, z / zeta**2, z * (1.0 + z) / zeta**3
        tail = (at + d1 * off + 0.5 * d2 * off**2) * s0 + (d1 + d2 * off) * step * s1 + 0.5 * d2 * step**2 * s2
        rho = 2.0 * np.pi * NU_HALF_BAND_PER_NM * step / np.abs(zeta)
        taylor = table.meta["tail"]["mass"] * rho**3 * np.abs(co.k) / np.abs(zeta)
        dropped = table.tail_bound(x_m)[None, :, None] * np.abs(co.k) / co.one_minus_q
    return np.where(taylor < dropped, (power * tail).real, 0.0)
