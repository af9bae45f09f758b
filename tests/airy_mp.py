"""Textbook Airy summation at arbitrary precision (mpmath): an independent reference, with the stiff and
random stacks the float64 paths are checked on and the backward-error bound they are held to.

r = (r12 + r23 z) / (1 + r12 r23 z) with Fresnel amplitudes from n cos θ;
deliberately the printed form, not lutbake's rearranged one.
"""

import mpmath as mp
import numpy as np

from lutbake.physics.optics import film_reflectance
from lutbake.physics.points import FilmPoints


def airy_reflectance_mp(eta1, eta2, eta3, kappa3, cos_theta1, thickness_nm, wavelength_nm, digits=50):
    """(R_s, R_p) as floats, of any real inputs (each taken as the float64 nearest it)."""
    inputs = (float(v) for v in (eta1, eta2, eta3, kappa3, cos_theta1, thickness_nm, wavelength_nm))
    with mp.workdps(digits):
        return tuple(float(r) for r in airy_reflectance_exact(*inputs))


def airy_reflectance_exact(eta1, eta2, eta3, kappa3, cos_theta1, thickness_nm, wavelength_nm):
    """(R_s, R_p) as mpf at the working precision, of float or mpf inputs."""
    e1, e2, e3, k3 = (mp.mpf(v) for v in (eta1, eta2, eta3, kappa3))
    c1, d, lam = mp.mpf(cos_theta1), mp.mpf(thickness_nm), mp.mpf(wavelength_nm)
    s2 = 1 - c1 * c1
    n2, n3 = mp.mpc(e2, 0), mp.mpc(e3, k3)
    g1 = mp.mpc(e1 * c1, 0)
    g2 = mp.sqrt(mp.mpc(e2 * e2 - e1 * e1 * s2, 0))
    g3 = mp.sqrt(mp.mpc(e3 * e3 - k3 * k3 - e1 * e1 * s2, 2 * e3 * k3))
    z = mp.exp(1j * 4 * mp.pi * d * g2 / lam)
    out = []
    for r12, r23 in (
        ((g1 - g2) / (g1 + g2), (g2 - g3) / (g2 + g3)),
        ((n2**2 * g1 - e1**2 * g2) / (n2**2 * g1 + e1**2 * g2), (n3**2 * g2 - n2**2 * g3) / (n3**2 * g2 + n2**2 * g3)),
    ):
        r = (r12 + r23 * z) / (1 + r12 * r23 * z)
        out.append(abs(r) ** 2)
    return out[0], out[1]


def random_cases(rng, n):
    """Random stacks covering TIR at top and base, η3 = η2, metals, grazing, d = 0."""
    eta1 = rng.choice([1.0, 1.0, 1.33, 2.0], n)
    eta2 = rng.uniform(1.0, 3.0, n)
    eta3 = rng.uniform(1.0, 4.0, n)
    kind = rng.integers(0, 6, n)
    eta3 = np.where(kind == 1, eta2, eta3)  # film matches base
    eta3 = np.where(kind == 2, eta2 * rng.uniform(0.3, 0.95, n), eta3)  # TIR at the base
    eta1 = np.where(kind == 3, eta2 * rng.uniform(1.05, 2.0, n), eta1)  # TIR at the top
    kappa3 = rng.choice([0.0, 0.0, 10.0, -1.0], n)
    kappa3 = np.where(kappa3 < 0, rng.uniform(0, 10, n), kappa3)
    theta = np.where(kind == 4, rng.uniform(89.0, 89.999, n), rng.uniform(0, 89.999, n))
    d = rng.choice([0.0, 5000.0, -1.0, -1.0], n)
    d = np.where(d < 0, rng.uniform(0, 5000, n), d)
    lam = rng.uniform(360, 830, n)
    return eta1, eta2, eta3, kappa3, theta, d, lam


def extreme_cases(rng, thickness_nm=(0.0, 2000.0)):
    """≥ 200 stiff stacks: grazing, near-critical films, huge κ, TIR, η3 ≈ η2."""
    cases = []
    for _ in range(50):
        e2 = rng.uniform(1.1, 3.0)
        lam = rng.uniform(360, 830)
        d = rng.uniform(*thickness_nm)
        near = 1 + rng.choice([-1e-9, 1e-9, -1e-6, 1e-6])
        cases += [
            (1.0, e2, rng.uniform(1, 4), rng.uniform(0, 100), rng.choice([1e-12, 1e-9, 1e-6, 1e-3]), d, lam),
            (3.5, e2, rng.uniform(1, 3), 0.0, np.sqrt(1 - (e2 / 3.5) ** 2 * near), d, lam),  # film near critical
            (1.0, e2, e2 * (1 + rng.choice([-1e-12, 1e-12])), rng.choice([0.0, 1e-9]), rng.uniform(0, 1), d, lam),
            (1.0, e2, 1.0, 0.0, rng.uniform(0, 1), d, lam),  # TIR at the base (η3 = 1 < η2)
            (1.0, e2, rng.uniform(1, 3), 0.0, np.cos(np.arctan(e2)) * near, d, lam),  # near Brewster (top)
        ]
    return cases


def input_sensitivity(case):
    """Σ_i |x_i ∂R/∂x_i| over the seven inputs, for (R_s, R_p): how far R moves when every input moves by
    one part in its own value (central differences at 50 digits, relative step 1e-20)."""
    out = np.zeros(2)
    with mp.workdps(50):
        for i, x in enumerate(case):
            step = mp.mpf(x) * mp.mpf(10) ** -20
            up, down = ([mp.mpf(v) + sign * step * (j == i) for j, v in enumerate(case)] for sign in (1, -1))
            out += [
                float(abs(a - b) / (2 * mp.mpf(10) ** -20))
                for a, b in zip(airy_reflectance_exact(*up), airy_reflectance_exact(*down))
            ]
    return out


def backward_error_ratios(reflectance, cases, backward_u):
    """|R − R at 50 digits| (n, 2) over the cases (η1, η2, η3, κ3, cos θ1, d, λ) of ``reflectance(case)`` →
    (R_s, R_p), each divided by what a backward-stable float64 R allows: the exact R of inputs within
    backward_u·u of theirs, rounded within backward_u·u, so |ΔR| ≤ backward_u·u·(Σ_i |x_i ∂R/∂x_i| + 1)."""
    u = np.finfo(float).eps / 2
    ratios = []
    for case in cases:
        ours = np.array(reflectance(case), float).reshape(2)
        ref = np.array(airy_reflectance_mp(*case))
        ratios.append(np.abs(ours - ref) / (backward_u * u * (input_sensitivity(case) + 1)))
    return np.array(ratios)


def stack_of(*columns):
    """Stacks of (η1, η2, η3, κ3, cos θ1, d) columns (scalars or arrays)."""
    fields = ("eta1", "eta2", "eta3", "kappa3", "cos_theta", "thickness_nm")
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(c, float)) for c in columns))
    return FilmPoints(**dict(zip(fields, (np.ascontiguousarray(a) for a in arrays))))


def optics_sp(columns):
    """(2, N) R_s, R_p of optics at N stacks, each at its own wavelength."""
    return np.stack(film_reflectance(stack_of(*columns[:6]), columns[6])[:2])


def optics_sensitivity(columns, step=1e-8):
    """(2, N) Σᵢ |xᵢ ∂R/∂xᵢ| over the seven inputs by central differences of optics at relative step 1e-8
    (its rounding adds ≤ 16u(Σ + 1)/1e-8 ~ 2e-7 (Σ + 1): the bound grows by as much). Where a resonance is
    narrower than the step (1 − |q| < 1e-8: cos θ1 ≲ 1e-8 over a metal) the quotient is the mean slope over
    the step, below the peak's: a bound built on it is tighter there than the model's, not looser."""
    out = np.zeros((2, len(columns[0])))
    for i in range(7):
        up, down = ([c * (1 + s * step) if j == i else c for j, c in enumerate(columns)] for s in (1, -1))
        out += np.abs(optics_sp(up) - optics_sp(down)) / (2 * step)
    return out
