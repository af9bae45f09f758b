"""The exact mode's shared cases: the KHR_materials_iridescence points the engine runs, the float64 evaluation
of the include's math and the ground truth at them (tests/engines/test_exact_engine.py, bench/bench_exact_mode.py),
and the search of the exact mode's error near the dielectric corner (tests/modes/test_exact.py,
bench/bench_exact_corner.py)."""

import sys
from pathlib import Path

import numpy as np

from lutbake.modes.exact import METALS, base_rgb, exact_colour
from lutbake.physics.colorimetry import delta_e00
from lutbake.physics.points import FilmPoints
from lutbake.quality.worstcase import SearchAxis, find_worst
from lutbake.spectral.reference import reference_colour

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs"))
import make_dropin  # noqa: E402  (the side-by-side page of docs/engines.md writes the exact table)

TABLE = make_dropin.EXACT_TABLE  # written by this lutbake on this machine (make_dropin.write_exact_table)
PER_BASE = 250
RGB_CALL = "lutbake_exact_rgb(lut, p.x, p.y, 1.0, p.z, q.xyz, r.xyz)"


def khr_points(seed=14):
    """(cos θ, d, η2, η3 (n, 3), κ3 (n, 3), base name) rounded to float32, as the GPU receives them."""
    rng = np.random.default_rng(seed)
    bases = ["dielectric"] * 4 + list(METALS)
    n = PER_BASE * len(bases)
    cos = rng.uniform(0.0, 1.0, n)
    kind = rng.random(n)
    cos[kind < 0.05], cos[(kind >= 0.05) & (kind < 0.1)] = 0.0, 1.0
    thickness = rng.uniform(100.0, 400.0, n)
    eta2 = np.where(rng.random(n) < 0.7, 1.3, rng.choice([1.2, 1.5, 2.0], n))
    name = np.repeat(bases, PER_BASE)
    eta3, kappa3 = np.empty((n, 3)), np.zeros((n, 3))
    dielectric = name == "dielectric"
    eta3[dielectric] = rng.uniform(1.0, 2.5, dielectric.sum())[:, None]
    eta3[np.flatnonzero(dielectric)[:8]] = 1.0  # the bare-ambient base: the hardest dielectric
    for metal in METALS:
        eta3[name == metal], kappa3[name == metal] = base_rgb(metal)
    f32 = [np.float32(v).astype(float) for v in (cos, thickness, eta2, eta3, kappa3)]
    return (*f32, name)


def float64_exact(table, cos, thickness, eta2, eta3, kappa3):
    """exact_colour per film index (it takes one η2 per call)."""
    values, terms = np.empty((cos.size, 3)), np.empty(cos.size, int)
    for e2 in np.unique(eta2):
        at = eta2 == e2
        result = exact_colour(table, cos[at], thickness[at], 1.0, e2, eta3[at], kappa3[at])
        values[at], terms[at] = result.values, result.terms
    return values, terms


def ground_truth(cos, thickness, eta2, eta3, kappa3):
    """Channel c integrated with the base's c-th (n, k); a base with one (n, k) for all three channels
    (the dielectrics) is integrated once for all three."""
    out = np.empty((cos.size, 3))
    one_index = (eta3 == eta3[:, :1]).all(axis=1) & (kappa3 == kappa3[:, :1]).all(axis=1)
    for c in range(3):
        at = np.arange(cos.size) if c == 0 else np.flatnonzero(~one_index)
        pts = FilmPoints.build(
            eta1=1.0,
            eta2=eta2[at],
            cos_theta=cos[at],
            thickness_nm=thickness[at],
            eta3=eta3[at, c],
            kappa3=kappa3[at, c],
        )
        values = reference_colour(pts).values
        out[at, c] = values[:, c]
        if c == 0:
            out[one_index, 1:] = values[one_index, 1:]
    return out


# The corner's neighbourhood: cos θ1, D (nm), η3 − η1, κ3 up to these, each cubed from the unit box so the
# decades near 0 are reached.
CORNER_SPAN = np.array([0.02, 20.0, 1e-3, 1e-3])


def corner_search(table, eta2, budget, seed=0):
    """find_worst of the exact mode's ΔE00 against the ground truth over the corner's neighbourhood (its
    corners, edges, the four singular faces, compass refinement): (max, (cos θ1, D, η3 − η1, κ3), how)."""

    def stack(u):
        v = CORNER_SPAN * np.asarray(u) ** 3
        return FilmPoints.build(
            eta1=1.0,
            eta2=eta2,
            cos_theta=v[:, 0],
            thickness_nm=v[:, 1] / (2.0 * eta2),
            eta3=1.0 + v[:, 2],
            kappa3=v[:, 3],
        )

    def error(u):
        st = stack(u)
        got = exact_colour(table, st.cos_theta, st.thickness_nm, 1.0, eta2, st.eta3, st.kappa3).values
        return delta_e00(got, reference_colour(st).values)

    axes = tuple(SearchAxis(name, cells=8) for name in ("cos_theta", "opd_nm", "eta3", "kappa3"))
    faces = {
        "cos θ → 0": {"cos_theta": 0.0},
        "D → 0": {"opd_nm": 0.0},
        "η3 → η1": {"eta3": 0.0},
        "κ3 → 0": {"kappa3": 0.0},
    }
    worst = find_worst(error, axes, singular=faces, budget=budget, seed=seed)
    return worst.value, CORNER_SPAN * worst.where**3, worst.best.how()
