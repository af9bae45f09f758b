// lutbake: spectral Airy reflectance of a thin film, integrated to RGB.
//
// One work-item per LUT texel of a band of image rows. Physics as in
// lutbake/optics.py (docs/optics.md): admittances Y1, Y2, Y3 per
// polarization (s: Y = g, p: Y = g/n^2, g = n cos θ), and
//     r = [N0 + N1·W] / [D0 + D1·W],  W = (e^{iΦ} − 1)/Y2,
// where only W depends on wavelength. Everything wavelength-independent is
// computed once per texel; the loop runs over the host's spectral rule
// (nodes uniform in wavenumber ν, RGB weights from lutbake.colorimetry).
//
// REAL is double (-DLUTBAKE_FP64) or float. The film phase is carried as a
// float-float product of host-split (hi, lo) inputs and reduced to a quarter
// turn before a polynomial sin/cos, so float32 keeps its phase to ~1e-7 rad
// for any film thickness. No libm call in the loop: PoCL can vectorize it.

#ifdef LUTBAKE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double REAL;
typedef double2 CPLX;
#else
typedef float REAL;
typedef float2 CPLX;
#endif

#define PI_R ((REAL)3.14159265358979323846)

inline CPLX c_mul(CPLX a, CPLX b) { return (CPLX)(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
inline CPLX c_div(CPLX a, CPLX b) {
    REAL d = b.x * b.x + b.y * b.y;
    return (CPLX)((a.x * b.x + a.y * b.y) / d, (a.y * b.x - a.x * b.y) / d);
}
inline REAL c_abs2(CPLX a) { return a.x * a.x + a.y * a.y; }

// Principal square root of z with Im z >= 0 (absorbing media only).
inline CPLX c_sqrt_upper(CPLX z) {
    REAL r = hypot(z.x, z.y);
    if (r == (REAL)0) return (CPLX)(0, 0);
    if (z.x >= (REAL)0) {
        REAL re = sqrt((REAL)0.5 * (r + z.x));
        return (CPLX)(re, z.y / (2 * re));
    }
    REAL im = sqrt((REAL)0.5 * (r - z.x));
    return (CPLX)(z.y / (2 * im), im);
}

// sin(πr), cos(πr) for |r| <= 1/4: Taylor series in x = πr, terms through x^17.
inline void sincospi_quarter(REAL r, REAL *s, REAL *c) {
    REAL x = PI_R * r, z = x * x;
    REAL ps = (REAL)-1.0 / 1307674368000;                 // -1/15!
    ps = ps * z + (REAL)1.0 / 6227020800;                 //  1/13!
    ps = ps * z - (REAL)1.0 / 39916800;                   // -1/11!
    ps = ps * z + (REAL)1.0 / 362880;                     //  1/9!
    ps = ps * z - (REAL)1.0 / 5040;
    ps = ps * z + (REAL)1.0 / 120;
    ps = ps * z - (REAL)1.0 / 6;
    *s = x + x * z * ps;
    REAL pc = (REAL)1.0 / 20922789888000;                 //  1/16!
    pc = pc * z - (REAL)1.0 / 87178291200;                // -1/14!
    pc = pc * z + (REAL)1.0 / 479001600;                  //  1/12!
    pc = pc * z - (REAL)1.0 / 3628800;
    pc = pc * z + (REAL)1.0 / 40320;
    pc = pc * z - (REAL)1.0 / 720;
    pc = pc * z + (REAL)1.0 / 24;
    pc = pc * z - (REAL)0.5;
    *c = (REAL)1 + z * pc;
}

// t = (a_hi + a_lo)(b_hi + b_lo) in turns; returns sin(πt), cos(πt), and t.
inline REAL sincospi_ff(REAL a_hi, REAL a_lo, REAL b_hi, REAL b_lo, REAL *s, REAL *c) {
    REAL p = a_hi * b_hi;
    REAL e = fma(a_hi, b_hi, -p) + (a_hi * b_lo + a_lo * b_hi);
    REAL q = rint(2 * p);                  // nearest quarter turn, exact
    REAL r = (p - (REAL)0.5 * q) + e;      // p − q/2 is exact (Sterbenz)
    REAL s0, c0;
    sincospi_quarter(r, &s0, &c0);
    int k = ((int)fmod(q, (REAL)4) + 4) & 3;
    *s = k == 0 ? s0 : k == 1 ? c0 : k == 2 ? -s0 : -c0;
    *c = k == 0 ? c0 : k == 1 ? -s0 : k == 2 ? -c0 : s0;
    return p + e;
}

// Compensated (Kahan) accumulation: up to 2048 float32 terms per channel
// would otherwise lose ~1e-5; exact compensation needs no reassociation
// (OpenCL forbids it unless -cl-fast-relaxed-math is given).
typedef struct { REAL sum, carry; } Accumulator;

inline void accumulate(Accumulator *a, REAL term) {
    const REAL y = term - a->carry;
    const REAL t = a->sum + y;
    a->carry = (t - a->sum) - y;
    a->sum = t;
}

typedef struct { CPLX n0, n1, d0, d1; } AiryTerms;

inline AiryTerms airy_terms(CPLX y1, CPLX y2, CPLX y3, REAL w_scale) {
    AiryTerms t;
    t.n0 = 2 * (y1 - y3);
    t.n1 = w_scale * c_mul(y1 + y2, y2 - y3);
    t.d0 = 2 * (y1 + y3);
    t.d1 = w_scale * c_mul(y1 - y2, y2 - y3);
    return t;
}

inline REAL airy_r2(AiryTerms t, CPLX w) {
    return c_abs2(t.n0 + c_mul(t.n1, w)) / c_abs2(t.d0 + c_mul(t.d1, w));
}

__kernel void bake_rows(
    __global const REAL *cos_axis,                            // N_cos
    __global const REAL *cos2_hi, __global const REAL *cos2_lo, // ±|cos θ2|, < 0: evanescent film
    __global const REAL *opd_hi, __global const REAL *opd_lo,   // N_opd
    __global const REAL *eta3_axis, __global const REAL *kappa3_axis,
    __global const REAL *nu_hi, __global const REAL *nu_lo,     // all ladder rules' nodes (1/nm)
    __global const REAL *weights,                             // per rule: 3 × count, row-major
    __global const int *levels,                               // rule level of each texel
    const REAL eta1, const REAL eta2,
    const int n_cos, const int n_opd, const int width, const int row0, const int n_min,
    __global REAL *rgb_out)                                   // rows × width × 3
{
    const int gid = get_global_id(0);
    const int x = gid % width, y = row0 + gid / width;
    const int i_cos = x % n_cos, i_eta3 = x / n_cos;
    const int i_opd = y % n_opd, i_kappa3 = y / n_opd;

    const REAL c1 = cos_axis[i_cos];
    const REAL e3 = eta3_axis[i_eta3], k3 = kappa3_axis[i_kappa3];
    // One host-computed cos θ2 feeds both the Fresnel terms and the phase, so
    // they agree even at the film's critical angle, where g2² is rounding noise.
    const bool evanescent = cos2_hi[i_cos] < 0;
    const REAL g2abs = eta2 * fabs(cos2_hi[i_cos]);
    const CPLX g1 = (CPLX)(eta1 * c1, 0);
    const CPLX g2 = evanescent ? (CPLX)(0, g2abs) : (CPLX)(g2abs, 0);
    const CPLX n3sq = (CPLX)((e3 - k3) * (e3 + k3), 2 * e3 * k3);
    // g3² = (n3² − η1²) + η1² cos² θ1: exact when η3 = η1, where n3² − η1² sin² θ1
    // cancels catastrophically at grazing incidence.
    const CPLX g3 = c_sqrt_upper((CPLX)((e3 - k3) * (e3 + k3) - eta1 * eta1 + eta1 * eta1 * c1 * c1,
                                        2 * e3 * k3));

    const AiryTerms ts = airy_terms(g1, g2, g3, 1);
    const AiryTerms tp = airy_terms(g1 / (eta1 * eta1), g2 / (eta2 * eta2),
                                    c_div(g3, n3sq), eta2 * eta2);

    const REAL d_hi = opd_hi[i_opd], d_lo = opd_lo[i_opd];
    const REAL b_hi = fabs(cos2_hi[i_cos]);
    const REAL b_lo = evanescent ? -cos2_lo[i_cos] : cos2_lo[i_cos];
    const REAL dc_hi = d_hi * b_hi;                            // D·|cos θ2| as float-float
    const REAL dc_lo = fma(d_hi, b_hi, -dc_hi) + (d_hi * b_lo + d_lo * b_hi);
    // Ladder rule k has n_min·2^k nodes, stored after those of rules 0 … k−1.
    const int n_nodes = n_min << levels[gid];
    const int first = n_nodes - n_min;
    __global const REAL *nu_h = nu_hi + first, *nu_l = nu_lo + first;
    __global const REAL *wt = weights + 3 * first;
    Accumulator r = {0, 0}, g = {0, 0}, b = {0, 0};

    for (int j = 0; j < n_nodes; ++j) {
        // W_s = (e^{iΦ} − 1)/g2 = i·(2πDν/η2)·exprel(iΦ); W_p = η2²·W_s (folded into tp).
        const REAL amp = 2 * PI_R * d_hi * nu_h[j] / eta2;
        CPLX w;
        if (!evanescent) {
            REAL s, c;
            const REAL t = sincospi_ff(dc_hi, dc_lo, nu_h[j], nu_l[j], &s, &c);
            const REAL sinc = t == 0 ? (REAL)1 : s / (PI_R * t);   // exprel(2πit) = e^{iπt} sinc
            w = (CPLX)(-amp * sinc * s, amp * sinc * c);
        } else {
            const REAL decay = 2 * PI_R * dc_hi * nu_h[j];        // −iΦ, real >= 0
            const REAL rel = decay == 0 ? (REAL)1 : -expm1(-decay) / decay;
            w = (CPLX)(0, amp * rel);
        }
        const REAL refl = c1 == 0 ? (REAL)1 : (REAL)0.5 * (airy_r2(ts, w) + airy_r2(tp, w));
        accumulate(&r, wt[j] * refl);
        accumulate(&g, wt[n_nodes + j] * refl);
        accumulate(&b, wt[2 * n_nodes + j] * refl);
    }
    rgb_out[3 * gid + 0] = r.sum;
    rgb_out[3 * gid + 1] = g.sum;
    rgb_out[3 * gid + 2] = b.sum;
}
