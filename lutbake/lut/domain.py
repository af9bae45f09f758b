"""A LUT's spec from a film and the axes given, the others the default set's (`bake --eta2`, `sweep`, `tune`).

An axis not given takes the default set's first LUT's (lutbake-eta2-1.33: dielectric bases). Two of its
features need the ambient at their low end: η3's admittance spacings are undefined below η1 (such an axis
falls back to uniform spacing there), and the grazing corner's zoom starts at η3 = η1 and needs the corner
inside the domain (a spec refused with the zoom is built again without it on the default axes).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from lutbake.errors import ParameterError
from lutbake.grid.spec import Axis, BakeSpec, parse_axis
from lutbake.io.names import ADMITTANCE_SPACINGS
from lutbake.lut.bake import default_specs

__all__ = ["lut_spec"]


def lut_spec(
    eta2: float | None,
    eta1: float = 1.0,
    cos_theta: str | None = None,
    opd_nm: str | None = None,
    eta3: str | None = None,
    kappa3: str | None = None,
    **settings: Any,  # BakeSpec's other fields, each of its own type
) -> BakeSpec:
    """The BakeSpec of film ``eta2`` under ambient ``eta1`` over the axes given as `bake` spells them
    ('A:B:N[:SPACING[:NODES:SCALE]]', ``grid.spec.parse_axis``); an axis given as None is the default set's
    (see the module docstring). ``settings``: BakeSpec's other fields (space, observer, precision, ...);
    precision None means 'float'. ParameterError when ``eta2`` is None or a value is not allowed.

    >>> spec = lut_spec(1.5, opd_nm="0:1000:16")
    >>> spec.axis["opd_nm"].count, spec.axis["eta3"].spacing, spec.precision
    (16, 'sqrt-admittance', 'float')
    >>> lut_spec(1.5, eta1=1.33).axis["eta3"].spacing  # the default η3 axis starts below this ambient
    'uniform'
    """
    if eta2 is None:
        raise ParameterError("{eta2} is required (the film index)")
    given = {"cos_theta": cos_theta, "opd_nm": opd_nm, "eta3": eta3, "kappa3": kappa3}
    template = next(iter(default_specs().values())).axes
    axes = tuple(parse_axis(a.name, text) if (text := given[a.name]) else _default_axis(a, eta1) for a in template)
    settings = {**settings, "precision": settings.get("precision") or "float"}
    settings = {k: v for k, v in settings.items() if v is not None}
    try:
        return BakeSpec(eta2=eta2, eta1=eta1, axes=axes, **settings)
    except ParameterError:  # the default axes' corner zoom needs the corner in the given domain; without it
        axes = tuple(a if given[a.name] else replace(a, corner=()) for a in axes)  # (or raise what else)
        return BakeSpec(eta2=eta2, eta1=eta1, axes=axes, **settings)


def _default_axis(axis: Axis, eta1: float) -> Axis:
    """A default axis as is, except η3's admittance spacing under an ambient above its low end (where
    that spacing is undefined): uniform there, without the corner zoom (which starts at η3 = η1)."""
    if axis.spacing in ADMITTANCE_SPACINGS and axis.lo < eta1:
        return replace(axis, spacing="uniform", corner=())
    return axis
