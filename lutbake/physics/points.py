"""Film stacks: the one type every stage takes (optics, both integrators, the samplers, the reports).

A ``FilmPoints`` holds P stacks as float64 arrays with named fields. A named
(dispersive) film or base replaces the constant η2 or η3/κ3 of every point at
each wavelength. ``build`` and ``from_csv`` validate user input and raise
ValueError with one line naming the value and what is allowed; hot paths
(a bake's texels, refinement loops) take ``texels`` or the plain constructor,
which check nothing: their coordinates come from a validated spec or LUT.
``opd_from_thickness`` and ``thickness_from_opd`` convert between a film's thickness d and its optical
path D = 2·η2·d (a LUT's second axis).
"""

from __future__ import annotations

import array
import csv
import io
import itertools
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from typing import IO, TYPE_CHECKING, Any

import numpy as np

from lutbake.errors import ParameterError
from lutbake.physics.materials import DispersiveMaterial, material

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = [
    "FilmPoints",
    "check_value",
    "inside_domain",
    "read_csv_columns",
    "MAX_CSV_POINTS",
    "MAX_CSV_LINE_BYTES",
    "dielectric_film",
    "CSV_COLUMNS",
    "opd_from_thickness",
    "thickness_from_opd",
]

# The per-point fields (the rest name materials).
_COLUMNS = ("eta1", "eta2", "eta3", "kappa3", "cos_theta", "thickness_nm")
CSV_COLUMNS = ("eta1", "eta2", "thickness_nm", "opd_nm", "cos_theta", "angle_deg", "eta3", "kappa3")

# name → (test, what is allowed); the one table every entry point validates with. Bounds are where the
# model stops being meaningful in float64 or physics (docs/stability.md, "Input domain"): indices in
# [0.01, 10] (no natural material lies outside in the visible; squares of 1e308 overflow to NaN),
# κ3 ≤ 1000, films up to 100 µm thick and optical path D = 2·η2·d up to 200 µm (the checked range;
# fringes there are far below what any observer resolves, and the spectral cost grows with D).
MAX_INDEX, MIN_INDEX, MAX_KAPPA = 10.0, 0.01, 1000.0
MAX_THICKNESS_NM, MAX_OPD_NM = 1e5, 2e5
# A named film whose κ exceeds this somewhere in 360–830 nm is refused: the model's film is lossless.
MAX_FILM_KAPPA = 0.01
_INDEX = (lambda v: (v >= MIN_INDEX) & (v <= MAX_INDEX), f"a number in [{MIN_INDEX:g}, {MAX_INDEX:g}]")
# a test takes a scalar or an array (inside_domain tests one value without building an array)
_DOMAIN: dict[str, tuple[Callable[[float | np.ndarray], bool | np.ndarray], str]] = {
    "eta1": _INDEX,
    "eta2": _INDEX,
    "eta3": _INDEX,
    "kappa3": (lambda v: (v >= 0) & (v <= MAX_KAPPA), f"a number in [0, {MAX_KAPPA:g}]"),
    "thickness_nm": (lambda v: (v >= 0) & (v <= MAX_THICKNESS_NM), f"a number in [0, {MAX_THICKNESS_NM:g}]"),
    "opd_nm": (lambda v: (v >= 0) & (v <= MAX_OPD_NM), f"a number in [0, {MAX_OPD_NM:g}]"),
    "cos_theta": (lambda v: (v >= 0) & (v <= 1), "a number in [0, 1]"),
    "angle_deg": (lambda v: (v >= 0) & (v <= 90), "a number in [0, 90]"),
    "wavelength_nm": (lambda v: (v >= 360) & (v <= 830), "a number in [360, 830]"),
    "max_de": (lambda v: (v >= 0.01) & (v <= 100), "a number in [0.01, 100]"),
}


def opd_from_thickness(thickness_nm: ArrayLike, eta2: ArrayLike) -> np.ndarray:
    """Optical path difference at normal incidence, D = 2·η2·d (nm)."""
    return 2.0 * np.asarray(eta2, dtype=float) * np.asarray(thickness_nm, dtype=float)


def thickness_from_opd(opd_nm: ArrayLike, eta2: ArrayLike) -> np.ndarray:
    """Physical film thickness d = D / (2·η2) (nm)."""
    return np.asarray(opd_nm, dtype=float) / (2.0 * np.asarray(eta2, dtype=float))


def check_value(name: str, values: ArrayLike) -> np.ndarray:
    """Validate an array against the domain of ``name``; return it as float64."""
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    test, allowed = _DOMAIN[name]
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(arr) | ~test(arr)
    if bad.any():
        raise ValueError(f"{name} = {float(arr[bad][0])!r} is not allowed: must be {allowed}")
    return arr


def inside_domain(name: str, value: float) -> bool:
    """Whether ``value`` is finite and inside the domain of ``name`` (the table above)."""
    test, _ = _DOMAIN[name]
    return bool(np.isfinite(value) and test(value))


@dataclass(kw_only=True)
class FilmPoints:
    """P film stacks: ambient η1 | film η2, thickness d | base η3 + iκ3, lit at cos θ1.

    Build with ``FilmPoints.build`` (keyword-only, validated, broadcast); every
    column is then a float64 array of shape (P,). The plain constructor (also
    keyword-only) checks nothing and takes any broadcastable arrays, e.g. (P, 1)
    columns (``as_column``) against a row of wavelengths.

    Attributes
    ----------
    eta1, eta2 : numpy.ndarray
        Refractive index of the ambient and of the film (real, ≥ 1 for the ambient).
    eta3, kappa3 : numpy.ndarray
        Base index: real part and extinction coefficient (κ3 = 0 for a dielectric).
    cos_theta : numpy.ndarray
        Cosine of the angle of incidence in the ambient, in [0, 1].
    thickness_nm : numpy.ndarray
        Physical film thickness d in nm (``opd_nm`` = 2·η2·d, the LUT axis).
    film, base : Material or None
        Named dispersive materials (``lutbake materials``); their indices are taken per wavelength
        and the constant columns are placeholders.

    Examples
    --------
    >>> import lutbake
    >>> soap = lutbake.FilmPoints.build(eta2=1.33, thickness_nm=[200.0, 400.0], angle_deg=60.0, eta3=1.33)
    >>> len(soap), soap.cos_theta.round(3).tolist(), soap.opd_nm.tolist()
    (2, [0.5, 0.5], [532.0, 1064.0])
    >>> lutbake.FilmPoints.build(eta2=1.33, thickness_nm=-1.0, cos_theta=1.0, eta3=1.5)
    Traceback (most recent call last):
    ...
    ValueError: thickness_nm = -1.0 is not allowed: must be a number in [0, 100000]
    """

    eta1: np.ndarray
    eta2: np.ndarray
    eta3: np.ndarray
    kappa3: np.ndarray
    cos_theta: np.ndarray
    thickness_nm: np.ndarray
    film: DispersiveMaterial | None = None
    base: DispersiveMaterial | None = None

    def __len__(self) -> int:
        return self.cos_theta.size

    @property
    def opd_nm(self) -> np.ndarray:
        """Optical path difference at normal incidence, D = 2·η2·d (nm): a LUT's second axis."""
        return opd_from_thickness(self.thickness_nm, self.eta2)

    def indices(self, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(η2, η3, κ3) at ``wavelength_nm``, broadcast with the stack's fields: a named film or base
        is taken at each wavelength, constant indices as they are."""
        lam = np.asarray(wavelength_nm, float)
        eta2 = self.film.index(lam)[0] if self.film else self.eta2
        eta3, kappa3 = self.base.index(lam) if self.base else (self.eta3, self.kappa3)
        eta2, eta3, kappa3, *_ = np.broadcast_arrays(eta2, eta3, kappa3, self.cos_theta, self.thickness_nm, lam)
        return eta2, eta3, kappa3

    def as_column(self) -> FilmPoints:
        """The stacks with every field as a (P, 1) column: against wavelengths (M,) they give (P, M)."""
        return replace(self, **{f: getattr(self, f)[:, None] for f in _COLUMNS})

    def require(self, owner: str, **fixed: float | str | None) -> FilmPoints:
        """This stack, when each field in ``fixed`` holds that value at every point: a number for an
        index, a material name or None for ``film`` and ``base``. A LUT, an atlas slice and a spec each
        hold one film: a stack of another is refused (ParameterError naming the field, its value and
        ``owner``'s), never evaluated with the wrong one. Check ``film``/``base`` before the indices
        they replace."""
        for name, want in fixed.items():
            if name in ("film", "base"):
                got = getattr(self, name)
                same = (got is None) == (want is None) and (got is None or got.page == material(want).page)
                value = got and got.name
            else:
                column = np.asarray(getattr(self, name))
                differs = column != want
                same, value = not differs.any(), float(column[differs].flat[0]) if differs.any() else None
            if not same:
                raise ParameterError(
                    f"{{{name}}} {{value}} differs from the {{owner}}'s {name} = {{want}}",
                    value=repr(value),
                    owner=owner,
                    want=repr(want),
                )
        return self

    @classmethod
    def texels(
        cls,
        *,
        eta1: ArrayLike,
        eta2: ArrayLike,
        cos_theta: ArrayLike,
        opd_nm: ArrayLike,
        eta3: ArrayLike,
        kappa3: ArrayLike,
    ) -> FilmPoints:
        """Stacks at LUT coordinates (cos θ1, D = 2·η2·d, η3, κ3) of the film η1 | η2, unchecked and
        broadcast without copies: for coordinates a validated spec or LUT produced (a bake's texels)."""
        e1, e2, cos, opd, e3, k3 = np.broadcast_arrays(
            *(np.asarray(v, float) for v in (eta1, eta2, cos_theta, opd_nm, eta3, kappa3))
        )
        return cls(eta1=e1, eta2=e2, eta3=e3, kappa3=k3, cos_theta=cos, thickness_nm=thickness_from_opd(opd, e2))

    @classmethod
    def build(
        cls,
        *,
        eta1: ArrayLike = 1.0,
        eta2: ArrayLike | None = None,
        thickness_nm: ArrayLike | None = None,
        opd_nm: ArrayLike | None = None,
        cos_theta: ArrayLike | None = None,
        angle_deg: ArrayLike | None = None,
        eta3: ArrayLike | None = None,
        kappa3: ArrayLike = 0.0,
        film: str | None = None,
        base: str | None = None,
    ) -> FilmPoints:
        """Validate and broadcast keyword columns (scalars or arrays)."""
        film_mat = dielectric_film(film) if film else None
        base_mat = material(base) if base else None
        _require_one("thickness_nm", thickness_nm, "opd_nm", opd_nm)  # so below, one of each pair is given
        _require_one("cos_theta", cos_theta, "angle_deg", angle_deg)
        if film_mat is None and eta2 is None:
            raise ParameterError("{eta2} is missing: give {eta2} or {film}")
        if base_mat is None and eta3 is None:
            raise ParameterError("{eta3} is missing: give {eta3} (and {kappa3}) or {base}")
        if opd_nm is not None and film_mat is not None:
            raise ParameterError("{opd_nm} needs a constant eta2; with {film} give {thickness_nm}")
        cols = {
            "eta1": check_value("eta1", eta1),
            "eta2": check_value("eta2", 1.0 if eta2 is None else eta2),
            "eta3": check_value("eta3", 1.0 if eta3 is None else eta3),
            "kappa3": check_value("kappa3", kappa3),
        }
        if cos_theta is not None:
            cols["cos_theta"] = check_value("cos_theta", cos_theta)
        elif angle_deg is not None:
            cols["cos_theta"] = np.cos(np.radians(check_value("angle_deg", angle_deg)))
        if thickness_nm is not None:
            cols["thickness_nm"] = check_value("thickness_nm", thickness_nm)
        elif opd_nm is not None:
            cols["thickness_nm"] = thickness_from_opd(check_value("opd_nm", opd_nm), cols["eta2"])
        eta2_max = np.max(film_mat.index(np.array([360.0, 830.0]))[0]) if film_mat else cols["eta2"]
        check_value("opd_nm", 2.0 * eta2_max * cols["thickness_nm"])
        arrays = dict(zip(cols, np.broadcast_arrays(*cols.values())))
        return cls(**{k: np.ascontiguousarray(v) for k, v in arrays.items()}, film=film_mat, base=base_mat)

    @classmethod
    def from_csv(
        cls, source: str | IO[bytes], defaults: Mapping[str, ArrayLike | None] | None = None, **given: ArrayLike | None
    ) -> FilmPoints:
        """Stacks from a points CSV whose header names columns from CSV_COLUMNS: ``source`` is its text or a
        binary file object, read line by line within the bounds of ``read_csv_columns``. ``given`` values
        (flags) fill columns the CSV lacks and may not repeat one; ``defaults`` (a LUT's film) fill what
        neither gives. A column that a named film or base would override is refused, not dropped."""
        columns = read_csv_columns(source)
        repeated = [name for name in columns if name in given]
        if repeated:
            raise ParameterError(
                "points CSV column {column} and {" + repeated[0] + "} both give it: give one", column=repeated[0]
            )
        # name -> a column or a material name; build checks each
        values: dict[str, Any] = {**(defaults or {}), **given, **columns}
        for named, replaced in (("film", ("eta2",)), ("base", ("eta3", "kappa3"))):
            clash = [name for name in replaced if name in columns]
            if values.get(named) and clash:
                raise ValueError(
                    f"points CSV column {clash[0]} conflicts with the {named} {values[named]!r}, whose "
                    "index it would replace: drop the column or the material"
                )
        return cls.build(**values)


# A points CSV is read line by line: a row of 8 numbers is under 200 bytes, so a longer line (a 200 kB field,
# /dev/zero) is refused as soon as it is seen, and a CSV of more points than ``eval`` can hold as rows in
# memory (~1 kB each with its output) is refused at the first point past the bound.
MAX_CSV_LINE_BYTES = 4096
MAX_CSV_POINTS = 1_000_000


def read_csv_columns(source: str | IO[bytes]) -> dict[str, np.ndarray]:
    """Column name → float64 array of a points CSV (``source``: its text or a binary file object).
    Blank lines are skipped; ValueError (one line, naming the line) for anything else that is not
    a header of known, distinct columns over rows of as many numbers, within the bounds above."""
    if isinstance(source, str):
        source = io.BytesIO(source.encode("utf-8"))
    reader = csv.reader(_bounded_lines(source))
    header: list[str] | None = None
    columns: dict[str, array.array[float]] = {}
    try:
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            if header is None:
                header = _csv_header(row)
                columns = {name: array.array("d") for name in header}
                continue
            if len(columns[header[0]]) == MAX_CSV_POINTS:
                raise ValueError(f"points CSV has more than {MAX_CSV_POINTS:,} points: split it")
            if len(row) != len(header):
                raise ValueError(f"points CSV line {reader.line_num} has {len(row)} fields, expected {len(header)}")
            for name, cell in zip(header, row):
                columns[name].append(_csv_number(cell, name, reader.line_num))
    except csv.Error as exc:
        raise ValueError(f"points CSV line {reader.line_num}: {exc}") from None
    if header is None or not len(columns[header[0]]):
        raise ValueError("points CSV needs a header row and at least one data row")
    return {name: np.frombuffer(values, dtype=np.float64).copy() for name, values in columns.items()}


def _bounded_lines(stream: IO[bytes]) -> Iterator[str]:
    """The lines of a binary ``stream`` as text, each refused past MAX_CSV_LINE_BYTES, a NUL or bad UTF-8."""
    for number in itertools.count(1):
        line = stream.readline(MAX_CSV_LINE_BYTES + 1)
        if not line:
            return
        if len(line) > MAX_CSV_LINE_BYTES:
            raise ValueError(f"points CSV line {number} is over {MAX_CSV_LINE_BYTES:,} bytes: not a CSV of numbers")
        if b"\0" in line:
            raise ValueError(f"points CSV line {number} holds a NUL byte: not a text file")
        try:
            yield line.decode("utf-8")
        except UnicodeDecodeError:
            raise ValueError(f"points CSV line {number} is not UTF-8 text") from None


def _csv_header(row: list[str]) -> list[str]:
    header = [h.strip() for h in row]
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise ValueError(f"points CSV column {name!r} appears twice: each column once")
        seen.add(name)
    unknown = [h for h in header if h not in CSV_COLUMNS]
    if unknown:
        raise ValueError(f"points CSV column {unknown[0]!r} is unknown: allowed {', '.join(CSV_COLUMNS)}")
    return header


def _csv_number(cell: str, name: str, line: int) -> float:
    try:
        return float(cell)
    except ValueError:
        shown = cell.strip() if len(cell.strip()) <= 40 else cell.strip()[:40] + "…"
        raise ValueError(f"points CSV line {line}: {name} = {shown!r} is not a number") from None


def dielectric_film(name: str) -> DispersiveMaterial:
    """The named material, refused when it absorbs (κ > MAX_FILM_KAPPA in 360–830 nm): the film layer
    of the model is lossless, so its κ would be dropped silently."""
    film = material(name)
    kappa = film.index(np.linspace(360.0, 830.0, 95))[1]
    if np.max(kappa) > MAX_FILM_KAPPA:
        raise ValueError(
            f"film {name!r} absorbs (kappa up to {np.max(kappa):.3g} in 360-830 nm): the film "
            f"must be a dielectric with kappa <= {MAX_FILM_KAPPA:g}; use it as the base instead"
        )
    return film


def _require_one(name_a: str, a: object, name_b: str, b: object) -> None:
    if (a is None) == (b is None):
        raise ValueError(f"give exactly one of {name_a} or {name_b}")
