// lutbake: spectral Airy reflectance of a thin film, integrated to RGB.
//
// One work-item per LUT texel of a band of image rows. Physics as in
// lutbake/physics/optics.py (docs/optics.md): admittances Y1, Y2, Y3 per
// polarization (s: Y = g, p: Y = g/n^2, g = n cos θ), and
//     r = [N0 + N1·W] / [D0 + D1·W],  W = (e^{iΦ} − 1)/Y2,
// where only W depends on wavelength. Everything wavelength-independent is
// computed once per texel; the loop runs over the host's spectral rule
// (nodes uniform in wavenumber ν, RGB weights from lutbake.physics.colorimetry).
//
// REAL is double (-DLUTBAKE_FP64) or float. The film phase is carried as a
// float-float product of host-split (hi, lo) inputs and reduced to a quarter
// turn before a polynomial sin/cos, so float32 keeps its phase to ~1e-7 rad
// for any film thickness. No libm call in the loop: PoCL can vectorize it.

// Contraction of a*b + c into fma is the compiler's choice unless forbidden, so
// runtimes differed (PoCL fused, Intel did not): every fma here is explicit.
#pragma OPENCL FP_CONTRACT OFF

#ifdef LUTBAKE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double REAL;
typedef double2 CPLX;
#else
typedef float REAL;
typedef float2 CPLX;
#endif

#define PI_R ((REAL)3.14159265358979323846)

// Every kernel takes its work-item count last: the host pads the global size to a multiple of one
// work-group size (lutbake/integrate/program.py: LOCAL_SIZE), so PoCL builds each kernel's work-group
// function once instead of once per grid size (~0.2 s each), and the padding returns at once.
#define ITEMS_GUARD const int gid = get_global_id(0); if (gid >= n_items) return;

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
    REAL ps = (REAL)-7.647163731819816e-13;                 // -1/15!
    ps = ps * z + (REAL)1.6059043836821613e-10;                 //  1/13!
    ps = ps * z - (REAL)2.505210838544172e-08;                   // -1/11!
    ps = ps * z + (REAL)2.7557319223985893e-06;                     //  1/9!
    ps = ps * z - (REAL)0.0001984126984126984;
    ps = ps * z + (REAL)0.008333333333333333;
    ps = ps * z - (REAL)0.16666666666666666;
    *s = x + x * z * ps;
    REAL pc = (REAL)4.779477332387385e-14;                 //  1/16!
    pc = pc * z - (REAL)1.1470745597729725e-11;                // -1/14!
    pc = pc * z + (REAL)2.08767569878681e-09;                  //  1/12!
    pc = pc * z - (REAL)2.755731922398589e-07;
    pc = pc * z + (REAL)2.48015873015873e-05;
    pc = pc * z - (REAL)0.001388888888888889;
    pc = pc * z + (REAL)0.041666666666666664;
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

typedef struct { CPLX n0, n1, d0, d1; REAL t16; } AiryTerms;

// w_max bounds |W| over the spectrum. R is homogeneous of degree 0 in the
// terms, so they are rescaled to make the denominator O(1): tiny admittances
// (cos θ1 → 0) then cannot underflow |den|² to 0/0.
inline AiryTerms airy_terms(CPLX y1, CPLX y2, CPLX y3, REAL w_scale, REAL w_max) {
    AiryTerms t;
    t.n0 = 2 * (y1 - y3);
    t.n1 = w_scale * c_mul(y1 + y2, y2 - y3);
    t.d0 = 2 * (y1 + y3);
    t.d1 = w_scale * c_mul(y1 - y2, y2 - y3);
    const REAL m = fmax(fmax(length(t.n0), length(t.n1) * w_max), fmax(length(t.d0), length(t.d1) * w_max));
    const REAL inv = m > 0 ? 1 / m : (REAL)1;
    t.n0 *= inv; t.n1 *= inv; t.d0 *= inv; t.d1 *= inv;
    // transmitted power = t16·e^{−Im Φ}/|den|², t16 = 16·Re Y1·Re Y3 on the same scale
    const REAL a = sqrt(y1.x) * sqrt(fmax(y3.x, (REAL)0)) * inv;
    t.t16 = 16 * a * a;
    return t;
}

// |r|² directly where it is ≤ 1/2, else 1 − T (the film is lossless): both
// are ratios of non-negative terms, so 0 ≤ R ≤ 1 by construction.
inline REAL airy_r2(AiryTerms t, CPLX w, REAL decay_factor) {
    const REAL num2 = c_abs2(t.n0 + c_mul(t.n1, w));
    const REAL den2 = c_abs2(t.d0 + c_mul(t.d1, w));
    return num2 <= (REAL)0.5 * den2 ? num2 / den2 : 1 - t.t16 * decay_factor / den2;
}

// Everything about a texel that does not depend on wavelength.
typedef struct {
    AiryTerms s, p;
    bool evanescent, grazing;
    REAL dc_hi, dc_lo;   // D·|cos θ2| as a float-float pair (turns per unit ν)
    REAL d_over_eta2;    // D / η2
} Texel;

// The Fresnel side of a texel (its AiryTerms), for the film phase bounded by w_max.
// cos2_hi: ±|cos θ2| from the host (< 0: evanescent film); one value feeds both the
// Fresnel terms and the phase, so they agree even at the film's critical angle, where g2²
// is rounding noise.
inline void fresnel_terms(REAL c1, REAL cos2_hi, REAL e3, REAL k3, REAL eta1, REAL eta2, REAL w_max,
                          AiryTerms *s, AiryTerms *p) {
    const REAL g2abs = eta2 * fabs(cos2_hi);
    const CPLX g1 = (CPLX)(eta1 * c1, 0);
    const CPLX g2 = cos2_hi < 0 ? (CPLX)(0, g2abs) : (CPLX)(g2abs, 0);
    const CPLX n3sq = (CPLX)((e3 - k3) * (e3 + k3), 2 * e3 * k3);
    // g3² = (n3² − η1²) + η1² cos² θ1 with n3² − η1² = (η3 − η1)(η3 + η1) − κ3²: exact
    // when η3 = η1 (Sterbenz), where n3² − η1² sin² θ1 cancels catastrophically at grazing
    // incidence and (η3² − κ3²) − η1² keeps the rounding error of η3 ± κ3 (1e-16 ≫ cos² θ1).
    const REAL offset3 = (e3 - eta1) * (e3 + eta1) - k3 * k3;
    const CPLX g3 = (offset3 == 0 && k3 == 0) ? g1   // base matches the ambient (cos² may underflow)
                  : c_sqrt_upper((CPLX)(offset3 + eta1 * eta1 * c1 * c1, 2 * e3 * k3));
    *s = airy_terms(g1, g2, g3, 1, w_max);
    *p = airy_terms(g1 / (eta1 * eta1), g2 / (eta2 * eta2), c_div(g3, n3sq), eta2 * eta2, w_max);
}

// |W| ≤ 2πDν/η2 (ν ≤ 1/360 nm⁻¹), times η2² for p
inline REAL w_bound(REAL d, REAL eta2) { return 2 * PI_R * d / (eta2 * (REAL)360); }

// The phase side: D·|cos θ2| as a float-float product, and D/η2.
inline void texel_phase(Texel *t, REAL cos2_hi, REAL cos2_lo, REAL d_hi, REAL d_lo, REAL eta2) {
    const REAL b_hi = fabs(cos2_hi);
    const REAL b_lo = t->evanescent ? -cos2_lo : cos2_lo;
    t->dc_hi = d_hi * b_hi;
    t->dc_lo = fma(d_hi, b_hi, -t->dc_hi) + (d_hi * b_lo + d_lo * b_hi);
    t->d_over_eta2 = d_hi / eta2;
}

inline Texel texel_setup(REAL c1, REAL cos2_hi, REAL cos2_lo, REAL d_hi, REAL d_lo,
                         REAL e3, REAL k3, REAL eta1, REAL eta2) {
    Texel t;
    t.evanescent = cos2_hi < 0;
    t.grazing = c1 == 0;
    fresnel_terms(c1, cos2_hi, e3, k3, eta1, eta2, w_bound(d_hi, eta2), &t.s, &t.p);
    texel_phase(&t, cos2_hi, cos2_lo, d_hi, d_lo, eta2);
    return t;
}

// Unpolarized R at wavenumber ν = nu_hi + nu_lo (1/nm).
inline REAL texel_reflectance(const Texel *t, REAL nu_hi, REAL nu_lo) {
    if (t->grazing) return (REAL)1;
    // W_s = (e^{iΦ} − 1)/g2 = i·(2πDν/η2)·exprel(iΦ); W_p = η2²·W_s (folded into t->p).
    const REAL amp = 2 * PI_R * t->d_over_eta2 * nu_hi;
    CPLX w;
    REAL decay_factor = 1;   // e^{−Im Φ}
    if (!t->evanescent) {
        REAL s, c;
        const REAL turns = sincospi_ff(t->dc_hi, t->dc_lo, nu_hi, nu_lo, &s, &c);
        const REAL sinc = turns == 0 ? (REAL)1 : s / (PI_R * turns);  // exprel(2πit) = e^{iπt} sinc
        w = (CPLX)(-amp * sinc * s, amp * sinc * c);
    } else {
        const REAL decay = 2 * PI_R * t->dc_hi * nu_hi;                // −iΦ, real >= 0
        const REAL rel = decay == 0 ? (REAL)1 : -expm1(-decay) / decay;
        w = (CPLX)(0, amp * rel);
        decay_factor = exp(-decay);
    }
    return (REAL)0.5 * (airy_r2(t->s, w, decay_factor) + airy_r2(t->p, w, decay_factor));
}

// RGB by the texel's spectral rule: Σ_j W_cj R(ν_j), compensated.
inline void direct_rgb(const Texel *t, __global const REAL *nu_h, __global const REAL *nu_l,
                       __global const REAL *wt, int n_nodes, __global REAL *rgb) {
    Accumulator r = {0, 0}, g = {0, 0}, b = {0, 0};
    for (int j = 0; j < n_nodes; ++j) {
        const REAL refl = texel_reflectance(t, nu_h[j], nu_l[j]);
        accumulate(&r, wt[j] * refl);
        accumulate(&g, wt[n_nodes + j] * refl);
        accumulate(&b, wt[2 * n_nodes + j] * refl);
    }
    rgb[0] = r.sum;
    rgb[1] = g.sum;
    rgb[2] = b.sum;
}

// The direct quadrature at listed texels of a band of rows starting at row0 (`texels`: their index in the
// band; `levels`: each one's rule level, k for n_min·2^k nodes).
__kernel void bake_texels_direct(
    __global const REAL *cos_axis,                            // N_cos
    __global const REAL *cos2_hi, __global const REAL *cos2_lo, // ±|cos θ2| per cos node
    __global const REAL *opd_hi, __global const REAL *opd_lo,   // N_opd × N_cos: D per (node, cos θ1 node)
    __global const REAL *eta3_column,                         // η3 per image column (width)
    __global const REAL *kappa3_nodes,                        // N_kappa3 × N_cos
    __global const REAL *nu_hi, __global const REAL *nu_lo,     // all ladder rules' nodes (1/nm)
    __global const REAL *weights,                             // per rule: 3 × count, row-major
    __global const int *texels, __global const int *levels,
    const REAL eta1, const REAL eta2,
    const int n_cos, const int n_opd, const int width, const int row0, const int n_min,
    __global REAL *rgb_out,                                   // rows × width × 3
    const int n_items)
{
    ITEMS_GUARD
    const int index = texels[gid];
    const int x = index % width, y = row0 + index / width;
    const int i_cos = x % n_cos;                              // the tile packing: lutbake/grid/layout.py
    const int i_opd = y % n_opd, i_kappa3 = y / n_opd;
    const int opd_at = i_opd * n_cos + i_cos;
    const Texel t = texel_setup(cos_axis[i_cos], cos2_hi[i_cos], cos2_lo[i_cos], opd_hi[opd_at],
                                opd_lo[opd_at], eta3_column[x], kappa3_nodes[i_kappa3 * n_cos + i_cos], eta1, eta2);

    // Ladder rule k has n_min·2^k nodes, stored after those of rules 0 … k−1.
    const int n_nodes = n_min << levels[gid];
    const int first = n_nodes - n_min;
    direct_rgb(&t, nu_hi + first, nu_lo + first, weights + 3 * first, n_nodes, rgb_out + 3 * index);
}

// R at arbitrary (stack, wavenumber) points, film and base indices per point
// (dispersive materials, taken at each point's wavelength): one work-item per
// point. Scene slices of named materials, `lutbake check` and the tests.
__kernel void reflectance_points(
    __global const REAL *cos1, __global const REAL *cos2_hi, __global const REAL *cos2_lo,
    __global const REAL *opd_hi, __global const REAL *opd_lo, __global const REAL *eta2,
    __global const REAL *eta3, __global const REAL *kappa3,
    __global const REAL *nu_hi, __global const REAL *nu_lo,
    const REAL eta1, __global REAL *r_out, const int n_items)
{
    ITEMS_GUARD
    const int i = gid;
    const Texel t = texel_setup(cos1[i], cos2_hi[i], cos2_lo[i], opd_hi[i], opd_lo[i],
                                eta3[i], kappa3[i], eta1, eta2[i]);
    r_out[i] = texel_reflectance(&t, nu_hi[i], nu_lo[i]);
}

// One film stack with indices per node (dispersive materials) at (cos θ1, d) points, by one
// spectral rule, in two passes. The Fresnel side depends on (cos θ1, node) only, so stack_terms
// computes it once per distinct cos θ1 × node (scaled for the thickest point, w_max: R is
// homogeneous in the terms) and stack_rgb sums each point's nodes from it.
#define STACK_TERMS 18   // AiryTerms s, p: n0, n1, d0, d1 (complex) and t16 each

inline void store_terms(__global REAL *out, AiryTerms a) {
    out[0] = a.n0.x; out[1] = a.n0.y; out[2] = a.n1.x; out[3] = a.n1.y;
    out[4] = a.d0.x; out[5] = a.d0.y; out[6] = a.d1.x; out[7] = a.d1.y; out[8] = a.t16;
}

inline AiryTerms load_terms(__global const REAL *in) {
    AiryTerms a;
    a.n0 = (CPLX)(in[0], in[1]); a.n1 = (CPLX)(in[2], in[3]);
    a.d0 = (CPLX)(in[4], in[5]); a.d1 = (CPLX)(in[6], in[7]); a.t16 = in[8];
    return a;
}

__kernel void stack_terms(
    __global const REAL *cos1,                                    // per distinct cos θ1 (K)
    __global const REAL *cos2_hi,                                 // K × N: ±|cos θ2| per node
    __global const REAL *eta2, __global const REAL *eta3, __global const REAL *kappa3,   // N
    const REAL eta1, const REAL d_max, const int n_nodes,
    __global REAL *terms_out,                                     // K × N × STACK_TERMS
    const int n_items)
{
    ITEMS_GUARD
    const int c = gid / n_nodes, j = gid % n_nodes;
    AiryTerms s, p;
    fresnel_terms(cos1[c], cos2_hi[gid], eta3[j], kappa3[j], eta1, eta2[j], w_bound(2 * eta2[j] * d_max, eta2[j]),
                  &s, &p);
    store_terms(terms_out + STACK_TERMS * gid, s);
    store_terms(terms_out + STACK_TERMS * gid + 9, p);
}

// Work-item (block, point): the point's partial sum over nodes [block·B, block·B + B), so a few
// stiff points on a fine rule still fill every core (the host adds the blocks), and neighbouring
// work-items read the same nodes.
__kernel void stack_rgb(
    __global const REAL *cos1,                                    // per distinct cos θ1 (K)
    __global const REAL *cos2_hi, __global const REAL *cos2_lo,   // K × N
    __global const REAL *terms,                                   // K × N × STACK_TERMS (stack_terms)
    __global const int *cos_index,                                // per point: its row in cos1
    __global const REAL *d_hi, __global const REAL *d_lo,         // per point: thickness (nm)
    __global const REAL *eta2,                                    // N
    __global const REAL *nu_hi, __global const REAL *nu_lo,       // N (1/nm)
    __global const REAL *weights,                                 // 3 × N
    const int n_nodes, const int block, const int n_points,
    __global REAL *rgb_out,                                       // blocks × points × 3
    const int n_items)
{
    ITEMS_GUARD
    const int i = gid % n_points, first = (gid / n_points) * block;
    const int c = cos_index[i];
    Texel t;
    t.grazing = cos1[c] == 0;
    Accumulator r = {0, 0}, g = {0, 0}, b = {0, 0};
    for (int j = first; j < min(first + block, n_nodes); ++j) {
        const int cj = c * n_nodes + j;
        // D = 2·η2(λ)·d as a float-float pair
        const REAL e2x2 = 2 * eta2[j];
        const REAL opd_hi = e2x2 * d_hi[i];
        const REAL opd_lo = fma(e2x2, d_hi[i], -opd_hi) + e2x2 * d_lo[i];
        t.evanescent = cos2_hi[cj] < 0;
        t.s = load_terms(terms + STACK_TERMS * cj);
        t.p = load_terms(terms + STACK_TERMS * cj + 9);
        texel_phase(&t, cos2_hi[cj], cos2_lo[cj], opd_hi, opd_lo, eta2[j]);
        const REAL refl = texel_reflectance(&t, nu_hi[j], nu_lo[j]);
        accumulate(&r, weights[j] * refl);
        accumulate(&g, weights[n_nodes + j] * refl);
        accumulate(&b, weights[2 * n_nodes + j] * refl);
    }
    rgb_out[3 * gid] = r.sum;
    rgb_out[3 * gid + 1] = g.sum;
    rgb_out[3 * gid + 2] = b.sum;
}

// ---------------------------------------------------------------------------
// Fourier-series integration (lutbake/spectral/fourier.py, docs/spectral.md). Per
// polarization |r|² = C0 + 2 Re Σ_m K q^{m−1} e^{i2πmXν}, so
//     RGB_c = ½ Σ_pol [C0 Ŵ_c(0) + 2 Re Σ_m K q^{m−1} Ŵ_c(mX)],
// Ŵ_c the Fourier transform of the colour weights, tabulated by the host as
// quintic pieces of Ŵ_c(x)·e^{−i2πxν0} at x = k·h. Folding e^{i2πXν0} into
// K and q (host: `turn`) makes each term one complex product and one table
// evaluation. The host gives C0, K, q, 1 − |q| per (cos θ, η3, κ3) and X per
// (cos θ, D), in float64 (lutbake.spectral.fourier.series_coefficients).
//
// X depends on (cos θ, D) only, so a bake evaluates the table once per (cos θ,
// D) pair and term (pair_transform) and every texel of the pair reads those
// values (bake_rows_series). A band runs in up to three passes: the series,
// then the texels it leaves (a list the series kernel appends to) by the
// poles' closed form (kernels/poles.cl), then what that leaves by the direct
// quadrature (bake_texels_direct).

typedef struct { CPLX k, q; REAL c0, one_minus_q; } SeriesPol;

inline SeriesPol series_pol(__global const REAL *c) {
    SeriesPol p = {(CPLX)(c[1], c[2]), (CPLX)(c[3], c[4]), c[0], c[5]};
    return p;
}

// A column's (cos θ, η3, κ3) constants of the rule, from the host (lutbake.integrate.series.series_chunks;
// they do not depend on D): |K|/(1 − |q|), |q|, log |q| and |K| per polarization, and `geometric`, the terms
// after which the remainder bound with sup |Ŵ| ≤ mass is ≤ tol (+1 for rounding).
#define COLUMN 24   // REAL per column: s, p (6 each), then the rule's 9, padded
typedef struct { REAL as, ap, qs, qp, log_qs, log_qp, ks, kp, geometric; } ColumnRule;

inline ColumnRule column_rule(__global const REAL *c) {
    ColumnRule r = {c[12], c[13], c[14], c[15], c[16], c[17], c[18], c[19], c[20]};
    return r;
}

// A texel's remainder bound after m terms, Σ_pol |K| |q|^m/(1 − |q|) · sup_{y ≥ (m+1)X} |Ŵ(y)|,
// with sup |Ŵ(y)| ≤ min(mass, edge/(2πy) + variation/(2πy)²) (tail: those three, largest channel).
// Everything but |q|^m is hoisted: the rule's loop is latency-bound scalar code.
typedef struct { REAL as, ap, qs, qp, mass, edge, variation, inv_2pi_x; } Remainder;

inline Remainder remainder_setup(ColumnRule c, REAL x, __global const REAL *tail) {
    Remainder r = {c.as, c.ap, c.qs, c.qp, tail[0], tail[1], tail[2], 1 / (2 * PI_R * x)};
    return r;
}

inline REAL remainder_after(const Remainder *r, REAL qs_m, REAL qp_m, int m) {
    const REAL u = r->inv_2pi_x / (REAL)(m + 1);   // 1/(2πy), y = (m+1)X
    return (r->as * qs_m + r->ap * qp_m) * fmin(r->mass, (r->edge + r->variation * u) * u);
}

// Demodulated Ŵ of the three channels at x = s·h (s within the table).
inline void weight_transform(__global const REAL *table, int intervals, REAL s, CPLX out[3]) {
    const int k = min((int)s, intervals - 1);
    const REAL t = s - (REAL)k;
    __global const REAL *c = table + 36 * k;      // [channel][power 0..5][re, im]
    for (int ch = 0; ch < 3; ++ch, c += 12) {
        CPLX v = (CPLX)(c[10], c[11]);
        for (int j = 4; j >= 0; --j) v = v * t + (CPLX)(c[2 * j], c[2 * j + 1]);
        out[ch] = v;
    }
}

// The most terms the series may take at X = x: as many as the table reaches (M·X ≤ x_max), `budget` at most.
inline int series_terms_cap(REAL x, REAL x_max, int budget) {
    return x == 0 ? 0 : (int)fmin(floor(x_max / x), (REAL)budget);
}

// Where the remainder test below passes whatever its rounding, its two exp are skipped (plan_rows: 1.1 -> 0.5
// CPU s over the default set on PoCL): past the column's `geometric` count (the host's ceil(log(tol/Σ)/log
// max|q|) + 1, Σ = (Σ_pol |K|/(1 − |q|)) · mass, the remainder's bound) max|q|^cap · Σ ≤ tol · max|q|, a
// slack of one factor max|q| ≤ e^{−2^−16}, which the kernel's rounding (≤ 3·cap·ε·|log max|q|| in the
// exponent, cap ≤ 512, and ~15 ε in the constants and tol; ε = 2^−24 in float32) cannot use up; the bound
// is computed as before. Same outcome texel for texel (tests/integrate/test_series_plan.py builds it with
// SURE_REMAINDER 0; docs/spectral.md "The remainder test where it is sure").
#define SURE_REMAINDER 1
#define REMAINDER_SURE(c, cap) \
    (SURE_REMAINDER && (REAL)(cap) > (c).geometric && fmax((c).log_qs, (c).log_qp) <= -(REAL)1.52587890625e-05)

// The rule for one texel: the most terms it may take (cap ≥ 0, series_terms_cap), or −1 where
// the series is not used: out of scope (evanescent film: one_minus_q < 0), or
// the remainder bound is not ≤ tol within the table (M·X ≤ x_max) and
// `budget` terms. Closed form (no loop). *bound gets the a-priori bound the
// series then enforces: tol plus the table's interpolation error carried
// through at most min(cap, 1/(1 − |q|)) terms of size |K|.
inline int series_cap(SeriesPol s, SeriesPol p, ColumnRule c, REAL x, REAL x_max, __global const REAL *tail,
                      REAL interp, REAL tol, int budget, REAL *bound) {
    *bound = 0;
    if (s.one_minus_q < 0) return -1;
    if (x == 0) return 0;
    const int cap = series_terms_cap(x, x_max, budget);
    if (!REMAINDER_SURE(c, cap)) {
        const Remainder r = remainder_setup(c, x, tail);
        // |q|^cap through exp/log: a bound, so full-precision pow (slow on CPU runtimes) is not needed
        const REAL qs_cap = cap == 0 ? (REAL)1 : exp(cap * c.log_qs), qp_cap = cap == 0 ? (REAL)1 : exp(cap * c.log_qp);
        if (remainder_after(&r, qs_cap, qp_cap, cap) > tol) return -1;
    }
    *bound = tol + interp * (c.ks * fmin((REAL)cap, 1 / s.one_minus_q) + c.kp * fmin((REAL)cap, 1 / p.one_minus_q));
    return cap;
}

// At least the terms series_rgb sums (≤ cap): the column's geometric count (the plan sizes each pair's
// table with it, without running the loop).
inline int series_terms_bound(ColumnRule c, REAL x, int cap) {
    return x == 0 ? 0 : (int)fmin((REAL)cap, c.geometric);
}

// RGB by the series, term by term until the remainder bound is ≤ tol (by `cap` terms at the latest);
// X = 0 sums it in closed form. Ŵ(mX) comes from the pair's shared values `w` where `shared` (6 REAL per
// term: three channels, re and im, demodulated; at least series_terms_bound of them), else from the table.
inline void series_rgb(SeriesPol s, SeriesPol p, ColumnRule column, REAL x, CPLX turn, int cap, int shared,
                       __global const REAL *w, __global const REAL *table, int intervals, REAL step,
                       __global const REAL *tail, REAL tol, __global REAL *rgb) {
    const REAL w0[3] = {table[0], table[12], table[24]};   // Ŵ_c(0), real
    const REAL c0 = (REAL)0.5 * (s.c0 + p.c0);
    REAL acc[3] = {0, 0, 0};
    if (x == 0) {   // Σ_m K q^{m−1} = K/(1 − q); K = 0 wherever |q| = 1
        CPLX a = (CPLX)(0, 0);
        if (s.k.x != 0 || s.k.y != 0) a += c_div(s.k, (CPLX)(1 - s.q.x, -s.q.y));
        if (p.k.x != 0 || p.k.y != 0) a += c_div(p.k, (CPLX)(1 - p.q.x, -p.q.y));
        for (int c = 0; c < 3; ++c) rgb[c] = (c0 + a.x) * w0[c];
        return;
    }
    const Remainder r = remainder_setup(column, x, tail);
    const CPLX qs_t = c_mul(s.q, turn), qp_t = c_mul(p.q, turn);
    CPLX ks = c_mul(s.k, turn), kp = c_mul(p.k, turn);   // K (q e^{i2πXν0})^{m−1} e^{i2πXν0}
    const REAL x_step = x / step;
    REAL qs_m = 1, qp_m = 1;
    for (int m = 1; m <= cap && remainder_after(&r, qs_m, qp_m, m - 1) > tol; ++m, w += 6) {
        CPLX v[3];
        if (shared) {
            v[0] = (CPLX)(w[0], w[1]); v[1] = (CPLX)(w[2], w[3]); v[2] = (CPLX)(w[4], w[5]);
        } else {
            weight_transform(table, intervals, m * x_step, v);
        }
        const CPLX a = ks + kp;
        for (int c = 0; c < 3; ++c) acc[c] += a.x * v[c].x - a.y * v[c].y;
        ks = c_mul(ks, qs_t);
        kp = c_mul(kp, qp_t);
        qs_m *= r.qs;
        qp_m *= r.qp;
    }
    for (int c = 0; c < 3; ++c) rgb[c] = c0 * w0[c] + acc[c];
}

#define SERIES_ARGS \
    __global const REAL *coefficients, /* per (i_kappa3, i_eta3, i_cos): s, p (6 REAL each), rule */ \
    __global const REAL *film,         /* per (i_opd, i_cos): X, e^{i2πXν0} (3 REAL) */           \
    __global const REAL *table, const int intervals, const REAL step,                             \
    __global const REAL *tail, const REAL interp, const REAL tol, const int budget  /* tail: mass, edge, variation */

// The texel's series constants, X and rule. `index` is its place in the band, row by row (rgb_out and the
// lists of texels left); the band's passes over all its texels take them column by column within groups
// of BAND_ROWS rows instead (BAND_TEXEL): neighbouring work-items then share (cos θ, η3, κ3) and step
// along D, so a SIMD vector's texels need about as many terms each and read the same column's constants,
// while consecutive vectors write neighbouring texels of the same rows.
#define SERIES_TEXEL(index)                                                                       \
    const int x = (index) % width, y = row0 + (index) / width;                                   \
    SERIES_TEXEL_AT(x, y)

#define BAND_ROWS 16   // rows per group of BAND_TEXEL's order
#define BAND_PLACE                                                                                \
    const int group = gid / (BAND_ROWS * width), first_row = group * BAND_ROWS;                  \
    const int group_rows = min(BAND_ROWS, n_items / width - first_row);                          \
    const int within = gid - first_row * width;                                                   \
    const int x = within / group_rows, y = row0 + first_row + within % group_rows;              \
    const int index = (y - row0) * width + x;
#define BAND_TEXEL BAND_PLACE SERIES_TEXEL_AT(x, y)

#define SERIES_TEXEL_AT(x, y)                                                                     \
    SERIES_CONSTANTS(x, y)                                                                        \
    REAL bound;                                                                                    \
    const int cap = series_cap(sp, pp, column, f[0], step * intervals, tail, interp, tol, budget, &bound);

#define SERIES_CONSTANTS(x, y)                                                                    \
    const int i_cos = (x) % n_cos, i_eta3 = (x) / n_cos;   /* the tile packing: lutbake/grid/layout.py */ \
    const int i_opd = (y) % n_opd, i_kappa3 = (y) / n_opd;                                        \
    const int pair = i_opd * n_cos + i_cos;                                                       \
    __global const REAL *co = coefficients + COLUMN * ((i_kappa3 * (width / n_cos) + i_eta3) * n_cos + i_cos); \
    __global const REAL *f = film + 3 * pair;                                                     \
    const SeriesPol sp = series_pol(co), pp = series_pol(co + 6);                                 \
    const ColumnRule column = column_rule(co);

// Ŵ(mX), m = 1 … terms, of each (cos θ, D) pair: `offset` (pairs + 1, from 0) places pair j's terms at
// out[6·offset[j] …]. The same evaluation, to the bit, as a texel evaluating its own terms.
__kernel void pair_transform(__global const REAL *film, __global const int *offset,
                             __global const REAL *table, const int intervals, const REAL step,
                             __global REAL *out, const int n_items)
{
    ITEMS_GUARD
    const REAL x_step = film[3 * gid] / step;
    const int first = offset[gid], count = offset[gid + 1] - first;
    for (int m = 1; m <= count; ++m) {
        CPLX w[3];
        weight_transform(table, intervals, m * x_step, w);
        __global REAL *o = out + 6 * (first + m - 1);
        o[0] = w[0].x; o[1] = w[0].y; o[2] = w[1].x; o[3] = w[1].y; o[4] = w[2].x; o[5] = w[2].y;
    }
}

// The bake's series kernels' work-item: its texel's constants and the terms it may take; a texel the series
// does not take is appended to `rest` (its band index; `rest_count` counts them) and the work-item is done.
// Where `planned`, the plan's list of the band's texels the series leaves (`left`: 1 at each) decides
// instead of the rule's remainder test (two exp a texel, ~20% of this pass on PoCL): the plan ran that test
// on the same texel (plan_rows), and the terms it may take are then series_terms_cap's, as series_cap's.
#define SERIES_OR_REST                                                                                       \
    ITEMS_GUARD BAND_PLACE SERIES_CONSTANTS(x, y)                                                           \
    int cap;                                                                                                  \
    if (planned) {                                                                                            \
        cap = left[index] ? -1 : series_terms_cap(f[0], step * intervals, budget);                           \
    } else {                                                                                                  \
        REAL bound;                                                                                           \
        cap = series_cap(sp, pp, column, f[0], step * intervals, tail, interp, tol, budget, &bound);         \
    }                                                                                                         \
    if (cap < 0) { rest[atomic_inc(rest_count)] = index; return; }
#define PLANNED_ARGS __global const char *left, const int planned

// The bake's first pass over a band: the series for every texel whose rule allows it, Ŵ(mX) read from its
// pair's shared values (`pair_w`, placed by `offset` as in pair_transform); the other texels are appended
// to `rest` (their band index; `rest_count` counts them).
__kernel void bake_rows_series(const int n_cos, const int n_opd, const int width, const int row0, SERIES_ARGS,
                               __global const int *offset, __global const REAL *pair_w, PLANNED_ARGS,
                               __global REAL *rgb_out, __global int *rest, __global int *rest_count,
                               const int n_items)
{
    SERIES_OR_REST
    // `shared` a literal: the compiler drops the other branch (a run-time flag made this 3x slower)
    series_rgb(sp, pp, column, f[0], (CPLX)(f[1], f[2]), cap, 1, pair_w + 6 * offset[pair], table, intervals, step,
               tail, tol, rgb_out + 3 * index);
}

// bake_rows_series where the pairs share nothing (few texels per pair, or their table would not fit):
// each texel evaluates the table for its own terms.
__kernel void bake_rows_series_table(const int n_cos, const int n_opd, const int width, const int row0, SERIES_ARGS,
                                     PLANNED_ARGS, __global REAL *rgb_out, __global int *rest, __global int *rest_count,
                                     const int n_items)
{
    SERIES_OR_REST
    series_rgb(sp, pp, column, f[0], (CPLX)(f[1], f[2]), cap, 0, table, table, intervals, step, tail, tol,
               rgb_out + 3 * index);
}
