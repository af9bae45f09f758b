"""Numerical stability on stiff and extreme cases (`lutbake check`).

Each case evaluates the fast path (the bake kernel on the default OpenCL
device, or the numpy path where none exists) and compares it with an
independent reference: the converged ground truth (lutbake/spectral/reference.py), a closed
form, the incoherent limit, or a physical identity, against a stated
tolerance. docs/stability.md lists the cases and what the code does at each.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from lutbake.grid.spec import Axis, BakeSpec
from lutbake.integrate.devices import device_key
from lutbake.integrate.opencl import backend as make_backend
from lutbake.io.progress import no_progress
from lutbake.physics.optics import film_reflectance, round_trip_amplitude
from lutbake.physics.points import FilmPoints
from lutbake.spectral.fourier import DEFAULT_SERIES_TOLERANCE, series_colour
from lutbake.spectral.reference import reference_colour

if TYPE_CHECKING:
    from pyopencl import Device

    from lutbake.integrate.numpy_path import NumpyBackend
    from lutbake.integrate.opencl import OpenCLBackend

__all__ = ["CheckResult", "CheckRun", "run_checks", "check_fast_path"]

SPECTRAL_TOLERANCE = 1e-5  # the ladder's design target (spectral.RuleLadder)
IDENTITY_TOLERANCE = 1e-9
FLOAT32_TOLERANCE = 2e-5
CAPPED_TOLERANCE = 1e-4  # past the node cap: the measured error a bake accepts without a warning
INCOHERENT_TOLERANCE = 2e-5  # D = 100 µm against the incoherent limit: measured 7.2e-6 (fringes 2 nm apart)
# Every tolerance is below 2e-4 in RGB (0.2 ΔE00 on mid grey): an answer that far off fails every case
# (tests/quality/test_stability.py builds one and checks that it does).


@dataclass
class CheckResult:
    group: str
    name: str
    value: float
    reference: float
    error: float
    tolerance: float
    note: str = ""

    @property
    def passed(self) -> bool:
        return bool(np.isfinite(self.error) and self.error <= self.tolerance)

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "passed": self.passed}


def _spec(eta2, eta1=1.0, compute="float64"):
    axes = (
        Axis("cos_theta", 0.0, 1.0, 2),
        Axis("opd_nm", 0.0, 1.0, 2),
        Axis("eta3", 1.0, 2.0, 2),
        Axis("kappa3", 0.0, 1.0, 2),
    )
    return BakeSpec(eta2=eta2, eta1=eta1, axes=axes, compute=compute)


class _Paths:
    """The fast path (per compute precision) and the ground truth at single stacks."""

    def __init__(self, fast, device=None):
        self._fast = {"float64": make_backend(fast, device=device) if isinstance(fast, str) else fast}

    def _backend(self, compute):
        """The float64 backend, or its device's float32 build (numpy has one precision)."""
        if compute not in self._fast:
            first = self._fast["float64"]
            self._fast[compute] = (
                first
                if first.name == "numpy"
                else make_backend("opencl", compute, first.integrator, device_key(first.ctx.devices[0]))
            )
        return self._fast[compute]

    def fast(self, eta1, eta2, cos_theta, opd_nm, eta3, kappa3, compute="float64"):
        stack = _stack(eta1, eta2, cos_theta, opd_nm, eta3, kappa3)
        return self._backend(compute).evaluate(_spec(eta2, eta1, compute), stack)

    @staticmethod
    def truth(eta1, eta2, cos_theta, opd_nm, eta3, kappa3):
        result = reference_colour(_stack(eta1, eta2, cos_theta, opd_nm, eta3, kappa3))
        return result.values, bool(result.converged.all())


def _stack(
    eta1: npt.ArrayLike,
    eta2: npt.ArrayLike,
    cos_theta: npt.ArrayLike,
    opd_nm: npt.ArrayLike,
    eta3: npt.ArrayLike,
    kappa3: npt.ArrayLike,
) -> FilmPoints:
    """The film stacks of a case: the tables below list each as (η1, η2, cos θ1, D, η3, κ3)."""
    return FilmPoints.build(eta1=eta1, eta2=eta2, cos_theta=cos_theta, opd_nm=opd_nm, eta3=eta3, kappa3=kappa3)


def _grey(eta1, eta2, eta3, kappa3, cos_theta):
    """Colour of a spectrally flat reflectance (a bare interface): R·(1, 1, 1)."""
    bare = FilmPoints(eta1=eta1, eta2=eta2, eta3=eta3, kappa3=kappa3, cos_theta=cos_theta, thickness_nm=0.0)
    return film_reflectance(bare, 550.0)[2]


def _vs_truth(paths, group, name, stack, note=""):
    fast = paths.fast(*stack)
    truth, converged = paths.truth(*stack)
    err = float(np.max(np.abs(fast - truth)))
    note = note + ("" if converged else " (reference not converged)")
    return CheckResult(group, name, float(fast[0, 1]), float(truth[0, 1]), err, SPECTRAL_TOLERANCE, note)


def _vs_value(paths, group, name, stack, expected, tolerance, note=""):
    fast = paths.fast(*stack)
    expected = np.broadcast_to(np.asarray(expected, float), fast.shape)
    err = float(np.max(np.abs(fast - expected)))
    return CheckResult(group, name, float(fast[0, 1]), float(expected[0, 1]), err, tolerance, note)


def _incoherent_limit(eta1, eta2, eta3, kappa3, cos_theta):
    """Thick-film limit: intensities add, R = R12 + (1−R12)²·R23 / (1 − R12·R23), per polarization."""
    top = FilmPoints(eta1=eta1, eta2=eta2, eta3=eta2, kappa3=0.0, cos_theta=cos_theta, thickness_nm=0.0)
    sin2 = (1 - cos_theta**2) * eta1**2 / eta2**2
    bottom = FilmPoints(eta1=eta2, eta2=eta2, eta3=eta3, kappa3=kappa3, cos_theta=np.sqrt(1 - sin2), thickness_nm=0.0)
    r12, r23 = film_reflectance(top, 550.0), film_reflectance(bottom, 550.0)
    pol = [a + (1 - a) ** 2 * b / (1 - a * b) for a, b in zip(r12[:2], r23[:2])]
    return 0.5 * (pol[0] + pol[1])


def _high_finesse(paths):
    g = "high finesse"
    return [
        _vs_truth(
            paths,
            g,
            "metal base κ3 = 10 at grazing (cos θ 0.02, D 3 µm)",
            (1.0, 1.5, 0.02, 3000.0, 1.2, 10.0),
            f"|r21·r23| = {float(round_trip_amplitude(1.0, 1.5, 1.2, 10.0, 0.02)):.4f}",
        ),
        # Total reflection at the base needs η3 < η1·sin θ1: a film in glass (η1 1.5) over air.
        _vs_truth(
            paths,
            g,
            "near-total reflection at the base, κ3 = 1e-3 (η1 1.5, η3 1.0)",
            (1.5, 2.0, 0.3, 5000.0, 1.0, 1e-3),
        ),
        _vs_value(
            paths,
            g,
            "lossless total reflection at the base: R ≡ 1",
            (1.5, 2.0, 0.3, 5000.0, 1.0, 0.0),
            1.0,
            IDENTITY_TOLERANCE,
            "every wavelength reflects totally",
        ),
        _vs_truth(
            paths,
            g,
            "total reflection at the top (η1 1.6 > η2 1.2): evanescent film",
            (1.6, 1.2, 0.3, 1000.0, 2.0, 0.5),
        ),
    ]


def _thick_films(paths):
    g = "thick films"
    out = [
        _vs_truth(paths, g, f"D = {d / 1000:g} µm on glass", (1.0, 1.5, 0.8, d, 1.0, 0.0)) for d in (20000.0, 100000.0)
    ]
    out.append(_vs_truth(paths, g, "D = 100 µm on a metal (η3 2, κ3 3)", (1.0, 1.5, 0.8, 100000.0, 2.0, 3.0)))
    limit = _incoherent_limit(1.0, 1.5, 1.0, 0.0, 0.8)
    truth, _ = paths.truth(1.0, 1.5, 0.8, 100000.0, 1.0, 0.0)
    out.append(
        CheckResult(
            g,
            "D = 100 µm tends to the incoherent limit (ground truth)",
            float(truth[0, 1]),
            float(limit),
            float(np.max(np.abs(truth - limit))),
            INCOHERENT_TOLERANCE,
            "fringes 2 nm apart average out under the CMFs",
        )
    )
    return out


def _degenerate(paths):
    g = "degenerate stacks"
    out = [
        _vs_value(
            paths,
            g,
            "d = 0: bare ambient|base interface",
            (1.0, 1.5, 0.7, 0.0, 2.0, 1.5),
            _grey(1.0, 1.0, 2.0, 1.5, 0.7),
            IDENTITY_TOLERANCE,
        ),
        _vs_value(
            paths,
            g,
            "D = 1e-9 nm: continuous with d = 0",
            (1.0, 1.5, 0.7, 1e-9, 2.0, 1.5),
            paths.fast(1.0, 1.5, 0.7, 0.0, 2.0, 1.5),
            IDENTITY_TOLERANCE,
        ),
        _vs_value(
            paths,
            g,
            "η2 = η1: bare ambient|base interface",
            (1.0, 1.0, 0.7, 2000.0, 2.0, 1.5),
            _grey(1.0, 1.0, 2.0, 1.5, 0.7),
            IDENTITY_TOLERANCE,
        ),
        _vs_value(
            paths,
            g,
            "η3 = η2, κ3 = 0: bare ambient|film interface",
            (1.0, 1.5, 0.7, 2000.0, 1.5, 0.0),
            _grey(1.0, 1.5, 1.5, 0.0, 0.7),
            IDENTITY_TOLERANCE,
        ),
        _vs_value(
            paths,
            g,
            "η3 = η2, κ3 = 1e-9: within 1e-8 of the bare interface",
            (1.0, 1.5, 0.7, 2000.0, 1.5, 1e-9),
            _grey(1.0, 1.5, 1.5, 0.0, 0.7),
            1e-8,
        ),
        _vs_value(
            paths,
            g,
            "κ3 = 0 vs 1e-12: continuous",
            (1.0, 1.5, 0.7, 2000.0, 2.0, 1e-12),
            paths.fast(1.0, 1.5, 0.7, 2000.0, 2.0, 0.0),
            IDENTITY_TOLERANCE,
        ),
        _vs_truth(paths, g, "κ3 = 100", (1.0, 1.5, 0.7, 2000.0, 2.0, 100.0)),
        _vs_truth(paths, g, "η3 = 1 (film in air)", (1.0, 1.33, 0.7, 2000.0, 1.0, 0.0)),
    ]
    return out


def _angles(paths):
    g = "angles"
    out = [
        _vs_value(
            paths,
            g,
            "cos θ = 0: total reflection",
            (1.0, 1.5, 0.0, 2000.0, 2.0, 1.0),
            1.0,
            1e-12,
            "RGB = Σ weights = 1 to rounding",
        ),
        _vs_truth(paths, g, "cos θ = 1e-12", (1.0, 1.5, 1e-12, 2000.0, 2.0, 1.0)),
        _vs_truth(paths, g, "cos θ = 1 (normal incidence)", (1.0, 1.5, 1.0, 2000.0, 2.0, 1.0)),
    ]
    # Brewster at the base, tan θ2 = η3/η2, is reachable from the ambient for η3 = 1.2 < η2.
    for label, theta, eta3 in (
        ("ambient|film", np.arctan(1.5), 2.0),
        ("film|base", np.arcsin(1.5 * np.sin(np.arctan(1.2 / 1.5))), 1.2),
    ):
        c = np.cos(theta + np.array([-1e-7, 1e-7]))
        rgb = paths.fast(1.0, 1.5, c, 800.0, eta3, 0.0)
        out.append(
            CheckResult(
                g,
                f"Brewster's angle at the {label} interface: R continuous",
                float(rgb[0, 1]),
                float(rgb[1, 1]),
                float(np.max(np.abs(rgb[0] - rgb[1]))),
                1e-6,
                "r_p passes through 0; its phase jumps by π",
            )
        )
    return out


def _float32(paths):
    g = "float32 kernel"
    rng = np.random.default_rng(2026)
    n = 400
    stacks = [
        (1.0, 1.5, rng.uniform(0, 1, n), rng.uniform(0, 20000, n), rng.uniform(1, 3, n), rng.uniform(0, 5, n)),
        (1.0, 2.0, rng.uniform(0, 0.1, n), rng.uniform(15000, 20000, n), rng.uniform(1, 3, n), rng.uniform(0, 10, n)),
    ]
    out = []
    for label, stack in zip(("random stacks, D ≤ 20 µm", "grazing, D 15–20 µm (Φ ≈ 1e3 rad)"), stacks):
        f64 = paths.fast(*stack)
        f32 = paths.fast(*stack, compute="float32")
        err = float(np.max(np.abs(f32 - f64)))
        out.append(
            CheckResult(
                g,
                f"float32 vs float64: {label}",
                float(f32[0, 1]),
                float(f64[0, 1]),
                err,
                FLOAT32_TOLERANCE,
                "float-float phase, quarter-turn reduction",
            )
        )
    return out


def _truncation(paths):
    """The ladder's cap is the spectral integral's truncation: below it the
    error target holds; beyond it the estimate the bake records must bound
    the actual error where it says something, and the error must stay below
    the level a bake accepts for its capped texels where it does not (the
    a-priori bound reaches 1 far past the cap: it holds for any answer)."""
    g = "truncation"
    spec = _spec(2.0)
    out = []
    for label, stack in (
        ("just past the cap (κ3 40, cos θ 0.05, D 20 µm)", (1.0, 2.0, 0.05, 20000.0, 2.5, 40.0)),
        ("far past the cap (κ3 100, cos θ 0.01, D 100 µm)", (1.0, 2.0, 0.01, 100000.0, 2.5, 100.0)),
    ):
        params = [np.array([v]) for v in stack[2:]]
        level = int(spec.cell_levels(*params)[0])
        estimate = float(spec.truncation_estimate(*params)[0])
        result = _vs_truth(paths, g, label, stack, f"{spec.ladder.counts[level]} nodes")
        if estimate > 0:
            result.tolerance = min(estimate, CAPPED_TOLERANCE)
            result.note += f"; the bound the bake records: {estimate:.1e}" + (
                "" if estimate <= CAPPED_TOLERANCE else f", held to {CAPPED_TOLERANCE:g} instead"
            )
        out.append(result)
    return out


def _series(eta1, eta2, cos_theta, opd_nm, eta3, kappa3, tolerance=DEFAULT_SERIES_TOLERANCE):
    return series_colour(_stack(eta1, eta2, cos_theta, opd_nm, eta3, kappa3), tolerance=tolerance)


def _fourier(paths):
    """The Fourier series (lutbake/spectral/fourier.py, the float64 twin of the kernel's
    bake_rows_series) at its hard cases, and its truncation bound."""
    return _fourier_cases(paths) + _fourier_limits(paths)


def _fourier_cases(paths):
    """The series against closed forms and the ground truth where it is hardest: no film (X = 0), grazing
    over a matched base, lossless total reflection, high finesse and a thick film."""
    g = "fourier series"
    out = []

    def case(name, stack, expected, tolerance, note=""):
        res = _series(*stack)
        expected = np.broadcast_to(np.asarray(expected, float), res.values.shape)
        err = float(np.max(np.abs(res.values - expected)))
        out.append(
            CheckResult(
                g,
                name,
                float(res.values[0, 1]),
                float(expected[0, 1]),
                err,
                tolerance,
                f"{int(res.terms[0])} terms" + (f"; {note}" if note else ""),
            )
        )

    bare = (1.0, 1.5, 0.7, 0.0, 2.0, 1.5)
    case("X = 0: closed form C0 + 2 Re K/(1 − q)", bare, _grey(1.0, 1.0, 2.0, 1.5, 0.7), IDENTITY_TOLERANCE)
    case(
        "cos θ = 0 over a matched base (q → 1, K = 0): R = 1",
        (1.0, 1.5, 0.0, 1000.0, 1.0, 0.0),
        paths.truth(1.0, 1.5, 0.0, 1000.0, 1.0, 0.0)[0],
        1e-12,
        "RGB = Σ weights",
    )
    case(
        "lossless total reflection at the base: K = 0, C0 = 1",
        (1.5, 2.0, 0.3, 5000.0, 1.0, 0.0),
        paths.truth(1.5, 2.0, 0.3, 5000.0, 1.0, 0.0)[0],
        IDENTITY_TOLERANCE,
    )
    for label, stack in (
        ("high finesse: metal κ3 10 at cos θ 0.05, D 3 µm", (1.0, 1.5, 0.05, 3000.0, 1.2, 10.0)),
        ("thick film: D = 20 µm on a metal", (1.0, 1.5, 0.8, 20000.0, 2.0, 3.0)),
    ):
        case(label, stack, paths.truth(*stack)[0], 1e-8)
    return out


def _fourier_limits(paths):
    """Where the series stops: an evanescent film, which it leaves to the direct path (−1 terms), and a sum
    stopped early by a loose tolerance, whose recorded bound must hold."""
    g = "fourier series"
    out = []
    evanescent = _series(1.6, 1.2, 0.3, 1000.0, 2.0, 0.5)
    out.append(
        CheckResult(
            g,
            "evanescent film: out of scope, left to the direct path",
            float(evanescent.terms[0]),
            -1.0,
            float(abs(evanescent.terms[0] + 1)),
            0.0,
        )
    )
    # With a loose tolerance the sum stops early: the bound it records must hold.
    stack = (1.0, 2.5, 0.05, 4000.0, 1.2, 20.0)
    res, truth = _series(*stack, tolerance=1e-4), paths.truth(*stack)[0]
    out.append(
        CheckResult(
            g,
            "truncation: stopped at a 1e-4 bound, error within the recorded bound",
            float(res.values[0, 1]),
            float(truth[0, 1]),
            float(np.max(np.abs(res.values - truth))),
            float(res.bound[0]),
            f"{int(res.terms[0])} terms, |q| near 1",
        )
    )
    return out


def run_checks(
    backend: str | OpenCLBackend | NumpyBackend = "auto",
    progress: Callable[..., None] = no_progress,
    device: str | Device | None = None,
) -> list[CheckResult]:
    """Every stiff and extreme case, each against an independent reference and a stated tolerance.

    Parameters
    ----------
    backend : str or backend
        The fast path to check: 'auto' (the default OpenCL device, else numpy), 'opencl', 'numpy', or a
        float64 backend already made (``integrate.backend``; its device's float32 build is checked too).
    progress : callable
        ``progress(done, total, note)`` before each group.
    device : str, optional
        OpenCL device of a ``backend`` given by name (see ``bake_lut``).

    Returns
    -------
    list of CheckResult
        One per case: group, name, value, reference, error, tolerance, note, ``passed``
        (docs/stability.md lists the cases).

    Examples
    --------
    >>> import lutbake
    >>> results = lutbake.run_checks()
    >>> len(results) > 20, all(r.passed for r in results)
    (True, True)
    """
    paths = _Paths(backend, device)
    results: list[CheckResult] = []
    groups = (_high_finesse, _thick_films, _degenerate, _angles, _float32, _truncation, _fourier)
    for i, group in enumerate(groups):
        progress(i, len(groups), group.__name__.strip("_").replace("_", " "))
        results.extend(group(paths))
    return results


@dataclass
class CheckRun:
    """What `lutbake check` reports: the device that ran the fast path, and every case's result."""

    device: str
    results: list[CheckResult]

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.results)

    def document(self) -> dict[str, Any]:
        """The JSON document `check --json` prints."""
        return {"passed": self.passed, "device": self.device, "checks": [r.as_dict() for r in self.results]}


def check_fast_path(
    backend: str = "auto", progress: Callable[..., None] = no_progress, device: str | Device | None = None
) -> CheckRun:
    """`lutbake check`: the fast path made once (one fallback warning, and its device named in the result),
    then ``run_checks`` on it; the parameters are ``run_checks``'s."""
    fast = make_backend(backend, device=device)
    return CheckRun(fast.device, run_checks(fast, progress))
