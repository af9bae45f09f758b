"""Ground truth: converged spectral integration of the exact Airy reflectance.

For each point, RGB (or XYZ) = ∫ w(λ)·R(λ) dλ over 360–830 nm, with w the
piecewise-linear illuminant-weighted sensitivity (lutbake/physics/colorimetry.py) and R the
float64 Airy reflectance (lutbake/physics/optics.py), indices taken at each wavelength for
dispersive materials; for constant indices and a propagating film R is taken in its phase-only
form (lutbake/physics/fringes.py: one cos and one sin per node, the same R to rounding). The
integral runs Gauss–Legendre on every 1 nm panel and doubles the nodes per panel until two
successive results agree to
``tolerance`` in every channel; the finer result is returned. Gauss–Legendre
converges exponentially on a resolved integrand, so the returned value's
error is far below the last difference (tests check ≤ 1e-7 against a rule
four times finer, for D up to 20 µm and near-resonant films).

This path is deliberately separate from the bake's wavenumber rule: tests,
``check`` and ``report`` measure the fast paths against it.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from lutbake.io.cores import usable_cores
from lutbake.physics.fringes import fringe_points, fringe_reflectance, fringe_terms
from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints
from lutbake.spectral.rules import SpectralRule, panel_rule

__all__ = [
    "ReferenceResult",
    "reference_colour",
    "reference_rgb",
    "spectral_reflectance",
    "subset",
    "unpolarized_reflectance",
]

DEFAULT_TOLERANCE = 1e-9
_START_NODES_PER_NM = 2
_MAX_NODES_PER_NM = 2048
# (point, node) pairs per chunk: the Airy arrays' ~20 complex temporaries of 64k pairs stay in cache, where
# 1M pairs (16 MB each) stream through memory at twice the CPU time (bench/bench_reference.py). Chunks are
# fixed by the points and the rule alone, so the result does not depend on how many threads run them.
_CELLS_PER_CHUNK = 65_536


@dataclass
class ReferenceResult:
    """Converged colour (P, 3) and the nodes per nm each point needed."""

    values: np.ndarray
    nodes_per_nm: np.ndarray
    converged: np.ndarray


def spectral_reflectance(points: FilmPoints, wavelength_nm: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(R_s, R_p, R) of every point at every wavelength, each (P, M)."""
    return film_reflectance(points.as_column(), np.asarray(wavelength_nm, float))


def unpolarized_reflectance(points: FilmPoints, wavelength_nm: np.ndarray) -> np.ndarray:
    """R (P, M) of every point at every wavelength: the Airy sum as a function of its phase
    (physics/fringes.py: constant indices and a propagating film, every glTF receipt's stack; one cos and one
    sin per node) where it applies, optics.film_reflectance at the rest."""
    fast = fringe_points(points)
    if fast.all():
        return fringe_reflectance(fringe_terms(points), wavelength_nm)
    out = np.empty((len(points), wavelength_nm.size))
    if fast.any():
        out[fast] = fringe_reflectance(fringe_terms(subset(points, fast)), wavelength_nm)
    out[~fast] = spectral_reflectance(subset(points, ~fast), wavelength_nm)[2]
    return out


def _integrate(points: FilmPoints, rule: SpectralRule, pool: ThreadPoolExecutor | None = None) -> np.ndarray:
    """The rule's sums at every point, chunk by chunk on ``pool``'s threads (numpy's loops release the
    interpreter, so the chunks run on every core), else in this thread. A rule finer than a chunk (a resonant
    point's 2048 nodes per nm: 963k nodes) is cut into spans of nodes summed in order, so its temporaries stay
    in cache too."""
    span = min(rule.count, _CELLS_PER_CHUNK)
    spans = range(0, rule.count, span)
    step = max(1, _CELLS_PER_CHUNK // rule.count)
    partial = np.empty((len(spans), len(points), rule.weights.shape[0]))

    def chunk(start: int, node: int) -> None:
        part = subset(points, slice(start, start + step))
        nodes = slice(node, node + span)
        reflectance = unpolarized_reflectance(part, rule.wavelength_nm[nodes])
        partial[node // span, start : start + step] = reflectance @ rule.weights[:, nodes].T

    jobs = [(start, node) for start in range(0, len(points), step) for node in spans]
    for _ in (pool.map if pool else map)(lambda job: chunk(*job), jobs):
        pass
    return partial.sum(axis=0) if len(spans) > 1 else partial[0]


def subset(points: FilmPoints, index: slice | np.ndarray) -> FilmPoints:
    """The points at ``index`` (a slice, an index array or a (P,) mask)."""
    return FilmPoints(
        eta1=points.eta1[index],
        eta2=points.eta2[index],
        eta3=points.eta3[index],
        kappa3=points.kappa3[index],
        cos_theta=points.cos_theta[index],
        thickness_nm=points.thickness_nm[index],
        film=points.film,
        base=points.base,
    )


def _rule(nodes_per_nm: int, observer: str, space: str, basis: str) -> SpectralRule:
    """The panel rule of ``basis`` ('rgb', 'xyz', or 'rgb+xyz': six rows, one reflectance pass)."""
    rules = [panel_rule(nodes_per_nm, observer, space, b) for b in basis.split("+")]
    if len(rules) == 1:
        return rules[0]
    return SpectralRule(rules[0].wavelength_nm, np.vstack([r.weights for r in rules]), basis)


def reference_colour(
    points: FilmPoints,
    observer: str = "cie1931",
    space: str = "rec709",
    basis: str = "rgb",
    tolerance: float = DEFAULT_TOLERANCE,
    workers: int | None = None,
) -> ReferenceResult:
    """Integrate each point until successive refinements agree to ``tolerance`` in every channel.

    Parameters
    ----------
    points : FilmPoints
        P film stacks.
    observer, space : str
        CIE observer ('cie1931', 'cie1964') and linear RGB space ('rec709', 'rec2020', 'p3', 'acescg').
    basis : str
        'rgb' or 'xyz' gives (P, 3) values; 'rgb+xyz' gives (P, 6), RGB then XYZ.
    tolerance : float
        Largest change in any channel between the last two refinements.
    workers : int, optional
        Threads integrating chunks of points at once (default: the cores this process may run on); the
        result is the same for any number.

    Returns
    -------
    ReferenceResult
        ``values`` (P, 3 or 6), ``nodes_per_nm`` each point needed, ``converged`` (False only where
        2048 nodes per nm were not enough).

    Examples
    --------
    Thick films need finer spectral sampling: their fringes are narrower.

    >>> import lutbake
    >>> films = lutbake.FilmPoints.build(eta2=1.5, thickness_nm=[100.0, 20000.0], cos_theta=1.0, eta3=1.0)
    >>> result = lutbake.reference_colour(films, basis="xyz")
    >>> result.values.shape, result.converged.tolist()
    ((2, 3), [True, True])
    >>> bool(result.nodes_per_nm[1] > result.nodes_per_nm[0])
    True
    """
    n = len(points)
    nodes = _START_NODES_PER_NM
    with ThreadPoolExecutor(workers or usable_cores(), thread_name_prefix="lutbake-truth") as pool:
        previous = _integrate(points, _rule(nodes, observer, space, basis), pool)
        values = previous.copy()
        needed = np.full(n, nodes)
        active = np.arange(n)
        while active.size and nodes < _MAX_NODES_PER_NM:
            nodes *= 2
            finer = _integrate(subset(points, active), _rule(nodes, observer, space, basis), pool)
            done = np.max(np.abs(finer - previous[active]), axis=1) <= tolerance
            values[active], needed[active] = finer, nodes
            previous[active] = finer
            active = active[~done]
    converged = np.ones(n, bool)
    converged[active] = False
    return ReferenceResult(values, needed, converged)


def reference_rgb(
    stack: FilmPoints, observer: str = "cie1931", space: str = "rec709", tolerance: float = DEFAULT_TOLERANCE
) -> np.ndarray:
    """Ground-truth linear RGB of film stacks: the converged spectral integral.

    Parameters
    ----------
    stack : FilmPoints
        P film stacks (``FilmPoints.build``): indices, cos θ1, thickness in nm.
    observer : str
        Colour-matching functions: 'cie1931' (2°) or 'cie1964' (10°).
    space : str
        Linear RGB space of the result: 'rec709' (sRGB primaries, D65), 'rec2020', 'p3' or 'acescg'.
    tolerance : float
        Largest change in any channel between the last two refinements (default 1e-9).

    Returns
    -------
    numpy.ndarray
        (P, 3) linear RGB; 1 is the reflectance of a perfect mirror (white).

    Examples
    --------
    A film too thin to interfere reflects like its bare base: glass (η = 1.5) at normal incidence
    reflects ((1.5 − 1)/(1.5 + 1))² = 4 % in every channel.

    >>> import lutbake
    >>> bare = lutbake.FilmPoints.build(eta2=1.33, thickness_nm=0.0, cos_theta=1.0, eta3=1.5)
    >>> [round(v, 6) for v in lutbake.reference_rgb(bare)[0].tolist()]
    [0.04, 0.04, 0.04]
    """
    return reference_colour(stack, observer, space, "rgb", tolerance).values
