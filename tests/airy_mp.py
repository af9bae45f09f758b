"""Textbook Airy summation at arbitrary precision (mpmath): an independent reference.

r = (r12 + r23 z) / (1 + r12 r23 z) with Fresnel amplitudes from n cos θ;
deliberately the printed form, not lutbake's rearranged one.
"""

import mpmath as mp


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
