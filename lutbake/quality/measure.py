"""How wrong a table is, measured: held-out points, their ground truth and scores, and the searched maximum.

The tools every measurement of lutbake's error shares — `lutbake report`, `sweep` and `tune`, and a
scene's jobs, which grow each slice and LUT until it meets its target (lutbake/scene/jobs.py,
lutbake/quality/refine.py). Held-out points are uniform over a LUT's domain, plus the centres of random
grid cells, where multilinear interpolation error peaks, at the float32 values a shader is given; their
colour is the ground-truth integrator's (lutbake/spectral/reference.py). Errors are CIEDE2000 in CIELAB
with the working space's white (``score``, ``ErrorStats``).

A maximum is searched, not sampled (lutbake/quality/worstcase.py): from the held-out points, the domain's
corners and edges and the places where the content is singular (D → 0, cos θ1 → 0, η3 → η1, κ3 → 0),
compass steps in the LUT's node coordinates climb the error measured against the bake's direct spectral
rule (``proxy_truth``: ~1e-6 from the ground truth in RGB, 60,000 points/s); the local maxima found are
then scored against the ground truth, and the max is the largest ground-truth ΔE00 of all points scored
(``search_max``; a scene atlas's slice: ``search_slice``). The report itself (tables, figures, HTML) is
lutbake/quality/report.py's.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from lutbake.grid.axis import Axis
from lutbake.lut.sample import Atlas, Lut
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.worstcase import Places, SearchAxis, WorstCase, find_worst
from lutbake.spectral.reference import reference_colour

if TYPE_CHECKING:
    from pyopencl import Device

# stack -> RGB (n, 3): a table's read, a truth or a proxy for it
Colours = Callable[[FilmPoints], np.ndarray]
# stack -> mask (n,): points a search leaves out
Exclusion = Callable[[FilmPoints], np.ndarray]

__all__ = [
    "HeldOutPoints",
    "held_out_points",
    "ErrorStats",
    "score",
    "search_max",
    "proxy_truth",
    "remembered",
    "lut_stacks",
    "shader_inputs",
    "singular_places",
    "corner_distance",
    "search_slice",
    "search_stacks",
    "SEARCH_BUDGET",
    "SLICE_SEARCH_BUDGET",
    "RESCORED",
]

SEARCH_BUDGET = 20000  # evaluations of each row's worst-case search (`report`)
SLICE_SEARCH_BUDGET = 2000  # a scene atlas slice's: 2D, scored against the ground truth itself
RESCORED = 10  # distinct local maxima of a search scored against the ground truth


@dataclass
class HeldOutPoints:
    """The held-out film stacks (one film, constant bases) and their ground truth."""

    stack: FilmPoints
    kind: np.ndarray  # "uniform" or "cell-centre"
    truth: np.ndarray

    def __len__(self) -> int:
        return self.kind.size


def held_out_points(
    axes: Sequence[Axis],
    eta1: float,
    eta2: float,
    observer: str,
    space: str,
    n_points: int,
    seed: int,
    centre_fraction: float = 0.5,
    truth: Colours | None = None,
) -> HeldOutPoints:
    """Uniform over the axes' domain, and a ``centre_fraction`` at centres of random cells of
    this grid (in node coordinates), where its interpolation error peaks, as float32 values (what a
    shader is given, ``shader_inputs``); their colour by ``truth`` (``stack -> RGB``; the ground truth,
    lutbake/spectral/reference.py, by default)."""
    rng = np.random.default_rng(seed)
    n_centre = int(n_points * centre_fraction)
    uniform = [rng.uniform(a.lo, a.hi, n_points - n_centre) for a in axes]
    units = np.column_stack([(rng.integers(0, a.count - 1, n_centre) + 0.5) / (a.count - 1) for a in axes])
    centres = lut_stacks(axes, eta1, eta2, units)
    cos_theta, opd_nm, eta3, kappa3 = (
        np.concatenate([u, c])
        for u, c in zip(uniform, (centres.cos_theta, centres.opd_nm, centres.eta3, centres.kappa3))
    )
    kind = np.array(["uniform"] * (n_points - n_centre) + ["cell-centre"] * n_centre)
    stack = shader_inputs(
        FilmPoints.build(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd_nm, eta3=eta3, kappa3=kappa3)
    )
    rgb = truth(stack) if truth else reference_colour(stack, observer, space).values
    return HeldOutPoints(stack, kind, rgb)


def lut_stacks(axes: Sequence[Axis], eta1: float, eta2: float, unit: npt.ArrayLike) -> FilmPoints:
    """Film stacks at unit node coordinates ``unit`` (n, 4) of the axes (each axis's node coordinate
    over N − 1; η3's "admittance" cells and the corner zoom's lie along cos θ1, so the other values follow
    the point's cos θ1)."""
    unit = np.asarray(unit, float)
    cos_theta = axes[0].from_unit(unit[:, 0])
    opd, eta3, kappa3 = (a.from_unit(unit[:, k], cos_theta, eta1) for k, a in enumerate(axes[1:], 1))
    return FilmPoints.texels(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd, eta3=eta3, kappa3=kappa3)


def singular_places(axes: Sequence[Axis], eta1: float) -> Places:
    """Where a LUT's content is singular, as worst-case search places (unit coordinates): a film of no
    thickness (D → 0), grazing incidence (cos θ1 → 0), a base that matches the ambient (η3 → η1) and a
    lossless one (κ3 → 0), each where the domain reaches it. Together they are the corner where the truth
    has no limit (docs/accuracy.md)."""
    cos_theta, opd, eta3, kappa3 = axes
    out: Places = {}
    if opd.lo == 0.0:
        out["D → 0"] = {"opd_nm": 0.0}
    if cos_theta.lo == 0.0:
        out["cos θ → 0"] = {"cos_theta": 0.0}
    if eta3.lo <= eta1 <= eta3.hi:  # an admittance spacing starts at η1 (lutbake/grid/axis.py): u = 0 at any cos θ1
        out["η3 → η1"] = {"eta3": float(eta3.to_unit(eta1, 1.0, eta1))}
    if kappa3.lo == 0.0:
        out["κ3 → 0"] = {"kappa3": 0.0}
    return out


def corner_distance(stack: FilmPoints, wavelength_nm: float = 550.0) -> np.ndarray:
    """How far each stack is from the corner where the truth has no limit, ρ (dimensionless).

    At cos θ1 → 0 over a base that matches the ambient (η3 → η1, κ3 → 0) and a film of no thickness
    (D → 0), the Airy reflectance tends to |2(Y1 − Y3) + iφY2|² / |2(Y1 + Y3) − iφY2|² per polarization,
    with Y1 = η1 cos θ1, Y2, Y3 the film's and the base's admittances and φ the film's phase: a function
    of their ratios only, so every neighbourhood of the corner holds every value (R = 0 with no film over
    a matched base, R = 1 at grazing). ρ = max(Y1, |Y3|, φ(λ)·Y2 / 2) at ``wavelength_nm`` is the scale
    of that neighbourhood: no interpolated table is right for every ρ → 0 (docs/accuracy.md)."""
    sin2 = stack.eta1**2 * (1.0 - stack.cos_theta**2)
    y1 = stack.eta1 * stack.cos_theta
    y2 = np.sqrt(np.maximum(stack.eta2**2 - sin2, 0.0))
    y3 = np.abs(np.sqrt((stack.eta3 + 1j * stack.kappa3) ** 2 - sin2))
    phase = 2.0 * np.pi * stack.opd_nm * (y2 / stack.eta2) / wavelength_nm
    return np.maximum(np.maximum(y1, y3), 0.5 * phase * y2)


def search_max(
    read: Colours,
    lut: Lut,
    pts: HeldOutPoints,
    de00: np.ndarray,
    proxy: Colours,
    budget: int = SEARCH_BUDGET,
    seed: int = 0,
    start_label: str = "held-out point",
    exclude: Exclusion | None = None,
) -> dict[str, Any]:
    """The searched maximum of ΔE00 between ``read(stack)`` and the ground truth over ``lut``'s domain.

    ``proxy(stack)`` (RGB) stands in for the ground truth while searching; the search starts from the
    scored points ``pts`` (their ground-truth ΔE00 ``de00``; ``start_label`` names them), and its distinct
    local maxima are scored against the ground truth. Returns the largest ground-truth ΔE00 of all points
    scored, where it is (``cos_theta``, ``opd_nm``, ``eta3``, ``kappa3``), how it was found, the LUT and
    truth there, the largest ΔE00 of ``pts`` and the evaluations the search spent. ``exclude(stack)``
    (a mask) leaves a region out: its points count as 0 (e.g. ``corner_distance(stack) < r``)."""
    if exclude is not None:
        de00 = np.where(exclude(pts.stack), 0.0, de00)
    worst = _climb(read, lut, pts, de00, proxy, budget, seed, exclude)
    found = worst.candidates[:RESCORED]
    how = [c.how().replace("given point", start_label, 1) for c in found]
    stack = shader_inputs(lut_stacks(lut.axes, lut.eta1, lut.eta2, np.array([c.where for c in found])))
    truth = reference_colour(stack, lut.meta["observer"], lut.meta["space"]).values
    with np.errstate(invalid="ignore", divide="ignore"):
        rgb = read(stack)
        scored = np.nan_to_num(delta_e00(rgb, truth, lut.meta["observer"], lut.meta["space"]), nan=np.inf)
    if exclude is not None:
        scored = np.where(exclude(stack), 0.0, scored)
    held = int(np.argmax(de00))
    if scored.max() >= de00[held]:
        i = int(np.argmax(scored))
        at, found_by, lut_rgb, truth_rgb = stack_point(stack, i), how[i], rgb[i], truth[i]
    else:
        at, found_by = stack_point(pts.stack, held), f"{start_label} ({pts.kind[held]})"
        lut_rgb, truth_rgb = read(pts.stack)[held], pts.truth[held]
    return {
        "de00_max": float(max(scored.max(), de00[held])),
        **at,
        "found_by": found_by,
        "lut_rgb": lut_rgb.tolist(),
        "truth_rgb": truth_rgb.tolist(),
        "held_out_max": float(de00[held]),
        "evaluations": worst.evaluations,
        "budget": budget,
        "local_maxima": [
            {
                **stack_point(stack, i),
                "de00": float(scored[i]),
                "found_by": how[i],
                "lut_rgb": rgb[i].tolist(),
                "truth_rgb": truth[i].tolist(),
            }
            for i in range(len(found))
        ],
    }


def _climb(
    read: Colours,
    lut: Lut,
    pts: HeldOutPoints,
    de00: np.ndarray,
    proxy: Colours,
    budget: int,
    seed: int,
    exclude: Exclusion | None,
) -> WorstCase:
    """worstcase.find_worst of ΔE00 between ``read`` and ``proxy`` over ``lut``'s node coordinates, from
    the points ``pts`` (ΔE00 ``de00``), at the inputs a shader is given; ``exclude``'s points count as 0."""
    space, observer, axes = lut.meta["space"], lut.meta["observer"], lut.axes

    def error(unit: np.ndarray) -> np.ndarray:
        stack = shader_inputs(lut_stacks(axes, lut.eta1, lut.eta2, unit))
        with np.errstate(invalid="ignore", divide="ignore"):  # NaN (a 0/0 in an approximation) is the worst
            de = delta_e00(read(stack), proxy(stack), observer, space)
        return de if exclude is None else np.where(exclude(stack), 0.0, de)

    given = np.column_stack(lut.node_coords(pts.stack)) / (np.array([a.count for a in axes]) - 1.0)
    return find_worst(
        error,
        tuple(SearchAxis(a.name, cells=a.count - 1) for a in axes),
        points=given,
        errors=de00,
        singular=singular_places(axes, lut.eta1),
        budget=budget,
        seed=seed,
    )


def shader_inputs(stack: FilmPoints) -> FilmPoints:
    """The stacks at float32 values of cos θ1, D, η3 and κ3, as a shader receives them: near the grazing
    corner the search reaches ratios (η3 − η1 against cos² θ1) that float32 inputs cannot carry, and every
    path, the LUT's too, is scored against the truth at the inputs it can be given."""
    return FilmPoints.texels(
        eta1=stack.eta1,
        eta2=stack.eta2,
        **{
            name: np.asarray(getattr(stack, name), np.float32).astype(float)
            for name in ("cos_theta", "opd_nm", "eta3", "kappa3")
        },
    )


def stack_point(stack: FilmPoints, i: int) -> dict[str, float]:
    """Stack ``i``'s (cos θ1, D, η3, κ3) by name, JSON-ready."""
    return {
        "cos_theta": float(stack.cos_theta[i]),
        "opd_nm": float(stack.opd_nm[i]),
        "eta3": float(stack.eta3[i]),
        "kappa3": float(stack.kappa3[i]),
    }


@dataclass
class ErrorStats:
    """ΔE00 statistics of one method over the held-out points, and its searched maximum (``worst_case``,
    ``search_max``'s result) when searched: the summary's ``de00_max`` is then the searched one."""

    name: str
    de00: np.ndarray = field(repr=False)
    rgb_abs_max: float
    seconds_per_eval: float = float("nan")
    worst_case: dict[str, Any] | None = None

    def summary(self) -> dict[str, Any]:
        de = self.de00
        searched = self.worst_case or {}
        return {
            "name": self.name,
            "de00_mean": float(de.mean()),
            "de00_p50": float(np.percentile(de, 50)),
            "de00_p95": float(np.percentile(de, 95)),
            "de00_p99": float(np.percentile(de, 99)),
            "de00_max": searched.get("de00_max", float(de.max())),
            "rgb_abs_max": self.rgb_abs_max,
            "ns_per_eval": self.seconds_per_eval * 1e9,
            "worst_case": self.worst_case,
        }


def score(
    name: str, rgb: np.ndarray, pts: HeldOutPoints, space: str, observer: str, seconds_per_eval: float = float("nan")
) -> ErrorStats:
    de = np.nan_to_num(delta_e00(rgb, pts.truth, observer, space), nan=np.inf)
    return ErrorStats(name, de, float(np.max(np.abs(rgb - pts.truth))), seconds_per_eval)


def proxy_truth(lut: Lut, backend: str = "auto", device: str | Device | None = None) -> Colours:
    """``stack -> RGB`` by the bake's direct spectral rule at its default sampling, for the LUT's film
    (OpenCL on ``device``, else numpy): the truth a worst-case search climbs, ~1e-6 from the ground truth in RGB at
    60,000 points/s (its maxima are then scored against the ground truth)."""
    from lutbake.grid.spec import BakeSpec
    from lutbake.integrate.opencl import backend as make_backend

    spec = BakeSpec(
        eta2=lut.eta2, eta1=lut.eta1, axes=tuple(lut.axes), space=lut.meta["space"], observer=lut.meta["observer"]
    )
    integrator = make_backend(backend, device=device)
    return lambda stack: integrator.evaluate(spec, stack)


def remembered(colours: Colours) -> Colours:
    """``colours`` answering a batch of stacks it has seen before from memory: every row of a report
    searches from the same corners, edges, singular faces and random scatter (the same seed), so the truth
    there is integrated once for all rows instead of once per row (the search itself is unchanged)."""
    seen: dict[bytes, np.ndarray] = {}

    def read(stack: FilmPoints) -> np.ndarray:
        key = hashlib.blake2b(repr((stack.film, stack.base)).encode())
        for field_values in (stack.eta1, stack.eta2, stack.eta3, stack.kappa3, stack.cos_theta, stack.thickness_nm):
            values = np.ascontiguousarray(field_values, float)
            key.update(repr(values.shape).encode() + values.tobytes())
        digest = key.digest()
        if digest not in seen:
            seen[digest] = colours(stack)
        return seen[digest].copy()

    return read


def search_slice(
    atlas: Atlas,
    s: dict[str, Any],
    cos_t: np.ndarray,
    thickness: np.ndarray,
    de00: np.ndarray,
    budget: int,
    seed: int,
    proxy: Colours | None = None,
) -> dict[str, Any]:
    """A slice's searched max (``search_stacks``) over its (√cos θ, thickness) grid, from its held-out points
    (``de00`` their ΔE00), the grid's corners and edges and grazing incidence (and d → 0 where it reaches)."""
    material, (_, _, w, h) = s["materials"][0], s["rect"]
    lo, hi = s["axes"]["thickness_nm"]["min"], s["axes"]["thickness_nm"]["max"]

    def stack_at(unit: np.ndarray) -> FilmPoints:
        return FilmPoints.build(
            cos_theta=unit[:, 0] ** 2, thickness_nm=lo + (hi - lo) * unit[:, 1], **atlas.film_stack(material)
        )

    given = np.column_stack([np.sqrt(cos_t), (thickness - lo) / (hi - lo) if hi > lo else 0.0 * cos_t])
    places = {"cos θ → 0": {"cos_theta": 0.0}} | ({"d → 0": {"thickness_nm": 0.0}} if lo == 0.0 else {})
    axes = (SearchAxis("cos_theta", cells=w - 1), SearchAxis("thickness_nm", cells=max(h - 1, 1)))
    found = search_stacks(
        stack_at,
        lambda stack: atlas.sample(material, stack),
        axes,
        given,
        de00,
        places,
        budget,
        seed,
        atlas.meta["space"],
        atlas.meta["observer"],
        proxy,
    )
    at = found.pop("at")
    return {
        "de00_max": found.pop("de00_max"),
        "cos_theta": float(at.cos_theta[0]),
        "thickness_nm": float(at.thickness_nm[0]),
        **found,
    }


def search_stacks(
    stack_at: Callable[[np.ndarray], FilmPoints],
    read: Colours,
    axes: Sequence[SearchAxis],
    given: np.ndarray,
    de00: np.ndarray,
    places: Places,
    budget: int,
    seed: int,
    space: str,
    observer: str,
    proxy: Colours | None = None,
) -> dict[str, Any]:
    """The searched max of ΔE00 between ``read(stack)`` and the ground truth over the unit box of ``axes``
    (``stack_at(unit) -> FilmPoints``): from the ``given`` points (unit coordinates, ``de00`` their ΔE00),
    the box's corners and edges and the singular ``places`` (worstcase.find_worst), climbed against the
    ground truth; or, given ``proxy`` (``stack -> RGB``, e.g. the bake's own integrator), climbed against it
    and its distinct local maxima and worst given point then scored against the ground truth, the largest
    of which is the max (``held_out_max`` that point's). Returns ``de00_max``, ``at`` (the stack there),
    ``found_by``, ``held_out_max``, ``evaluations``, ``budget``."""

    def ground_truth(stack: FilmPoints) -> np.ndarray:
        return reference_colour(stack, observer, space).values

    def error(unit: np.ndarray, truth: Colours = proxy or ground_truth) -> np.ndarray:

        stack = stack_at(unit)
        return delta_e00(read(stack), truth(stack), observer, space)

    worst = find_worst(error, axes, points=given, errors=de00, singular=places, budget=budget, seed=seed)
    found = worst.candidates[: RESCORED if proxy else 1]
    where = [c.where for c in found]
    how = [c.how().replace("given point", "held-out point", 1) for c in found]
    if proxy:  # the worst given point too, so that the max is never below the points it started from
        where, how = where + [given[int(np.argmax(de00))]], how + ["held-out point"]
    scored = error(np.array(where), ground_truth) if proxy else np.array([worst.value])
    best = int(np.argmax(scored))
    return {
        "de00_max": float(scored[best]),
        "at": stack_at(np.asarray(where[best])[None]),
        "found_by": how[best],
        "held_out_max": float(scored[-1] if proxy else np.max(de00)),
        "evaluations": worst.evaluations,
        "budget": budget,
    }
