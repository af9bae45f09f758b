"""The tests' reference quadrature over the visible band: 32-node Gauss–Legendre in long double on pieces
of the 1 nm panels, with nodes and weights from mpmath, and the rounding bounds the tests' tolerances
are built from (first order, per node: each operation's relative error counted in units of u).

numpy's leggauss is no reference: its weights' error grows with the node count (hundreds of ε at 32
nodes; at 2,048 per nm it put a double-precision reference 1.5e-12 off, above the bound it checked).
Where long double is double, U_LONG is double's and every bound grows with it (the tests stay sound).
"""

import functools

import mpmath as mp
import numpy as np

from lutbake.physics.colorimetry import colorimetry

LONG = np.longdouble
U_LONG = float(np.finfo(LONG).eps) / 2  # 2^-64 on x86-64 (80-bit)
U_DOUBLE = float(np.finfo(float).eps) / 2
NODES = 32
BAND_NM = (360, 830)  # the colour weights' 1 nm table spans it


@functools.lru_cache(maxsize=4)
def gauss_legendre(nodes=NODES):
    """(nodes, weights) of Gauss–Legendre on [−1, 1] and 2π, from mpmath at 40 digits (Newton on the
    Legendre recurrence), each rounded once to long double."""
    with mp.workdps(40):

        def legendre(t):  # P_n(t), P_{n−1}(t)
            p0, p1 = mp.mpf(1), t
            for k in range(2, nodes + 1):
                p0, p1 = p1, ((2 * k - 1) * t * p1 - (k - 1) * p0) / k
            return p1, p0

        x, omega = [], []
        for i in range(nodes):
            t = mp.cos(mp.pi * (i + 0.75) / (nodes + 0.5))
            for _ in range(100):
                p, p_before = legendre(t)
                step = p * (t * t - 1) / (nodes * (t * p - p_before))
                t -= step
                if abs(step) < mp.mpf(10) ** -36:
                    break
            x.append(mp.nstr(t, 30))
            omega.append(mp.nstr(2 * (1 - t * t) / (nodes * legendre(t)[1]) ** 2, 30))
        two_pi = mp.nstr(2 * mp.pi, 30)
    return np.array(x, LONG), np.array(omega, LONG), LONG(two_pi)


def graded_pieces(poles_nm=()):
    """[a, b] pieces of the band: the 1 nm panels (the colour weights are linear on each) cut at
    Re P ± Im P·2^j (j ≥ 0, to 2 nm) around every pole P of the integrand, so each piece lies at least
    its half-length from every pole: its Bernstein ρ ≥ 1 + √2 (checked here), where 32 nodes leave
    ρ^−64 < 4e-25 of the piece's integrand."""
    edges = [np.arange(BAND_NM[0], BAND_NM[1] + 1.0)]
    for p in poles_nm:
        steps = p.imag * 2.0 ** np.arange(max(1, int(np.ceil(np.log2(2.0 / p.imag)))) + 1)
        edges += [p.real + steps, p.real - steps]
    cuts = np.unique(np.clip(np.concatenate(edges), *BAND_NM))
    a, b = cuts[:-1], cuts[1:]
    if len(poles_nm):
        t = (np.asarray(poles_nm)[None, :] - 0.5 * (a + b)[:, None]) / (0.5 * (b - a)[:, None])
        s = np.sqrt(t - 1) * np.sqrt(t + 1)
        assert np.maximum(np.abs(t + s), np.abs(t - s)).min() >= 2.4
    return a, b


class BandRule:
    """Nodes λ (N,), the colour-weighted quadrature weights W = w_c(λ)·h·ω (3, N), and a bound on each
    W's rounding, all long double, on ``graded_pieces(poles_nm)``; w_c is the 1 nm table's linear
    interpolation (as colorimetry.sensitivity defines it).

    Rounding of W, per node (u = U_LONG): λ = m + h x with m, h exact (float64 ends in a 64-bit
    significand) and x, h·x, the sum rounded: the node moves ≤ 2uλ; w_c = y0 + (y1 − y0)(λ − j) (λ − j
    exact): 3u(|y0| + |y1|), and the node's move 2uλ|y1 − y0|; ω rounded, h·ω and the product with w_c:
    3u|W|. So |ΔW| ≤ u·h·ω·[(3 + 2λ)(|y0| + |y1|) + 3|w_c|]."""

    def __init__(self, poles_nm=()):
        x, omega, self.two_pi = gauss_legendre()
        a, b = graded_pieces(poles_nm)
        m, h = (LONG(a) + LONG(b)) / 2, (LONG(b) - LONG(a)) / 2
        self.nm = (m[:, None] + h[:, None] * x).ravel()
        h_omega = (h[:, None] * omega).ravel()
        table = colorimetry("cie1931", "rec709").rgb_table  # (3, 471): 360 … 830 nm
        j = np.minimum(np.floor(self.nm), BAND_NM[1] - 1).astype(int)
        y0, y1 = table[:, j - BAND_NM[0]].astype(LONG), table[:, j + 1 - BAND_NM[0]].astype(LONG)
        w = y0 + (y1 - y0) * (self.nm - j)
        self.weights = w * h_omega
        self.weights_rounding = U_LONG * h_omega * ((3 + 2 * self.nm) * (np.abs(y0) + np.abs(y1)) + 3 * np.abs(w))

    def integral(self, values, values_rounding):
        """Σ W f over the nodes for f = ``values`` (N,) complex, each within ``values_rounding`` (N,) (its
        own rounding, absolute), as double (3,), and the bound on its rounding (3,): the terms' (W's,
        f's, the product's u) plus their sum's, in any order, √2 γ_N Σ|W f|, plus the rounding to double."""
        terms = self.weights * values
        total = terms.sum(axis=1).astype(complex)
        size = np.abs(self.weights) * np.abs(values)
        n = self.nm.size
        gamma = n * U_LONG / (1 - n * U_LONG)
        per_term = self.weights_rounding * np.abs(values) + np.abs(self.weights) * values_rounding + U_LONG * size
        bound = (per_term.sum(axis=1) + np.sqrt(2) * gamma * size.sum(axis=1)).astype(float)
        return total, bound + U_DOUBLE * np.abs(total)
