"""Film stacks: the one type every stage takes (optics, both integrators, the samplers, the reports).

A ``FilmPoints`` holds P stacks as float64 arrays with named fields. A named
(dispersive) film or base replaces the constant η2 or η3/κ3 of every point at
each wavelength. ``build`` and ``from_csv`` validate user input and raise
ValueError with one line naming the value and what is allowed; hot paths
(a bake's texels, refinement loops) take ``texels`` or the plain constructor,
which check nothing: their coordinates come from a validated spec or LUT.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass, replace

import numpy as np

from .materials import material
from .errors import ParameterError
from .optics import opd_from_thickness, thickness_from_opd

__all__ = ["FilmPoints", "check_value", "dielectric_film", "CSV_COLUMNS"]

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
_DOMAIN = {
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


def check_value(name: str, values) -> np.ndarray:
    """Validate an array against the domain of ``name``; return it as float64."""
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    test, allowed = _DOMAIN[name]
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(arr) | ~test(arr)
    if bad.any():
        raise ValueError(f"{name} = {float(arr[bad][0])!r} is not allowed: must be {allowed}")
    return arr


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
    film: object = None
    base: object = None

    def __len__(self) -> int:
        return self.cos_theta.size

    @property
    def opd_nm(self) -> np.ndarray:
        """Optical path difference at normal incidence, D = 2·η2·d (nm): a LUT's second axis."""
        return opd_from_thickness(self.thickness_nm, self.eta2)

    def indices(self, wavelength_nm):
        """(η2, η3, κ3) at ``wavelength_nm``, broadcast with the stack's fields: a named film or base
        is taken at each wavelength, constant indices as they are."""
        lam = np.asarray(wavelength_nm, float)
        eta2 = self.film.index(lam)[0] if self.film else self.eta2
        eta3, kappa3 = self.base.index(lam) if self.base else (self.eta3, self.kappa3)
        return tuple(np.broadcast_arrays(eta2, eta3, kappa3, self.cos_theta, self.thickness_nm, lam)[:3])

    def as_column(self) -> "FilmPoints":
        """The stacks with every field as a (P, 1) column: against wavelengths (M,) they give (P, M)."""
        return replace(self, **{f: getattr(self, f)[:, None] for f in _COLUMNS})

    def require(self, owner: str, **fixed) -> "FilmPoints":
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
                raise ParameterError(f"{{{name}}} {{value}} differs from the {{owner}}'s {name} = {{want}}",
                                     value=repr(value), owner=owner, want=repr(want))
        return self

    @classmethod
    def texels(cls, *, eta1: float, eta2: float, cos_theta, opd_nm, eta3, kappa3) -> "FilmPoints":
        """Stacks at LUT coordinates (cos θ1, D = 2·η2·d, η3, κ3) of the film η1 | η2, unchecked and
        broadcast without copies: for coordinates a validated spec or LUT produced (a bake's texels)."""
        eta1, eta2, cos_theta, opd_nm, eta3, kappa3 = np.broadcast_arrays(
            *(np.asarray(v, float) for v in (eta1, eta2, cos_theta, opd_nm, eta3, kappa3)))
        return cls(eta1=eta1, eta2=eta2, eta3=eta3, kappa3=kappa3, cos_theta=cos_theta,
                   thickness_nm=thickness_from_opd(opd_nm, eta2))

    @classmethod
    def build(cls, *, eta1=1.0, eta2=None, thickness_nm=None, opd_nm=None, cos_theta=None,
              angle_deg=None, eta3=None, kappa3=0.0, film=None, base=None) -> "FilmPoints":
        """Validate and broadcast keyword columns (scalars or arrays)."""
        film_mat = dielectric_film(film) if film else None
        base_mat = material(base) if base else None
        _require_one("thickness_nm", thickness_nm, "opd_nm", opd_nm)
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
        else:
            cols["cos_theta"] = np.cos(np.radians(check_value("angle_deg", angle_deg)))
        if thickness_nm is not None:
            cols["thickness_nm"] = check_value("thickness_nm", thickness_nm)
        else:
            cols["thickness_nm"] = thickness_from_opd(check_value("opd_nm", opd_nm), cols["eta2"])
        eta2_max = np.max(film_mat.index(np.array([360.0, 830.0]))[0]) if film_mat else cols["eta2"]
        check_value("opd_nm", 2.0 * eta2_max * cols["thickness_nm"])
        arrays = dict(zip(cols, np.broadcast_arrays(*cols.values())))
        return cls(**{k: np.ascontiguousarray(v) for k, v in arrays.items()},
                   film=film_mat, base=base_mat)

    @classmethod
    def from_csv(cls, text: str, **defaults) -> "FilmPoints":
        """Parse CSV text whose header names columns from CSV_COLUMNS."""
        rows = list(csv.reader(io.StringIO(text)))
        rows = [r for r in rows if r and any(c.strip() for c in r)]
        if len(rows) < 2:
            raise ValueError("points CSV needs a header row and at least one data row")
        header = [h.strip() for h in rows[0]]
        repeated = [h for i, h in enumerate(header) if h in header[:i]]
        if repeated:
            raise ValueError(f"points CSV column {repeated[0]!r} appears twice: each column once")
        unknown = [h for h in header if h not in CSV_COLUMNS]
        if unknown:
            raise ValueError(f"points CSV column {unknown[0]!r} is unknown: allowed {', '.join(CSV_COLUMNS)}")
        columns = {h: [] for h in header}
        for line, row in enumerate(rows[1:], start=2):
            if len(row) != len(header):
                raise ValueError(f"points CSV line {line} has {len(row)} fields, expected {len(header)}")
            for h, cell in zip(header, row):
                try:
                    columns[h].append(float(cell))
                except ValueError:
                    raise ValueError(f"points CSV line {line}: {h} = {cell.strip()!r} is not a number") from None
        return cls.build(**{**defaults, **{k: np.array(v) for k, v in columns.items()}})


def dielectric_film(name: str):
    """The named material, refused when it absorbs (κ > MAX_FILM_KAPPA in 360–830 nm): the film layer
    of the model is lossless, so its κ would be dropped silently."""
    film = material(name)
    kappa = film.index(np.linspace(360.0, 830.0, 95))[1]
    if np.max(kappa) > MAX_FILM_KAPPA:
        raise ValueError(f"film {name!r} absorbs (kappa up to {np.max(kappa):.3g} in 360-830 nm): the film "
                         f"must be a dielectric with kappa <= {MAX_FILM_KAPPA:g}; use it as the base instead")
    return film


def _require_one(name_a, a, name_b, b):
    if (a is None) == (b is None):
        raise ValueError(f"give exactly one of {name_a} or {name_b}")
