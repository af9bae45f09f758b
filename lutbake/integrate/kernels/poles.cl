// lutbake: the spectral integral in closed form by the poles of the Airy series (lutbake/spectral/poles.py,
// whose docstring derives it; docs/spectral.md). Appended to airy.cl; the host defines the tables' geometry
// (CAUCHY_*, CHEB_NODES, …) from lutbake/spectral/poles.py when it builds the program
// (lutbake/integrate/program.py: kernel_defines).
//
// Per polarization, I_c = Σ_m K q^{m−1} Ŵ_c(mX) = ∫ w_c f dλ with f = K z/(1 − q z), z = e^{i2πX/λ},
// whose poles are P_n = 1/p_n, p_n = ζ + n/X, ζ = i log q/(2πX), residues R_n = (K/q) P_n²/(i2πX):
//     I_c = Σ_{near} R_n Γ_c(P_n) + Σ_i Ω_ci h(λ_i),   h = f − Σ_{near} R_n/(λ − P_n),
// near = inside the Bernstein ellipse E_NEAR_RHO of the band, Γ_c the weights' Cauchy transform
// (tables), Ω the Chebyshev product rule. float64 only: in float32 the pole positions carry too little
// of q (the texels go to the direct quadrature).

inline CPLX c_log(CPLX z) { return (CPLX)(log(length(z)), atan2(z.y, z.x)); }
inline CPLX c_recip(CPLX z) { return c_div((CPLX)(1, 0), z); }
inline CPLX c_scale(CPLX z, REAL s) { return (CPLX)(z.x * s, z.y * s); }

// ρ of the Bernstein ellipse of [360, 830] nm through P (any square root of w² − 1 will do: max of both).
inline REAL bernstein_rho(CPLX P) {
    const CPLX w = (CPLX)((P.x - BAND_CENTRE) / BAND_HALF, P.y / BAND_HALF);
    const CPLX s = c_sqrt_upper(c_mul(w, w) - (CPLX)(1, 0));
    return fmax(length(w + s), length(w - s));
}

inline REAL semi_major(REAL rho) { return BAND_HALF * (REAL)0.5 * (rho + 1 / rho); }

#define CAUCHY_ARGS \
    __global const REAL *cauchy_shallow, /* (cells, 3, SHALLOW_DEGREE + 1, re/im) */       \
    __global const REAL *cauchy_deep,    /* (cells, 3, DEEP_DEGREE + 1, re/im) */          \
    __global const REAL *cauchy_knots,   /* a (3 × N_KNOTS), then b (3 × N_KNOTS) */       \
    __global const REAL *cheb,           /* nodes (CHEB_NODES), weights (3 × CHEB_NODES) */ \
    const REAL gamma_bound, const REAL weight_mass

#define CAUCHY_PASS cauchy_shallow, cauchy_deep, cauchy_knots, cheb, gamma_bound, weight_mass

// Σ_m c_m u^m for the three channels' coefficient rows (degree d, complex, contiguous).
inline void horner3(__global const REAL *c, int d, CPLX u, CPLX g[3]) {
    for (int ch = 0; ch < 3; ++ch, c += 2 * (d + 1)) {
        CPLX v = (CPLX)(c[2 * d], c[2 * d + 1]);
        for (int m = d - 1; m >= 0; --m) v = c_mul(v, u) + (CPLX)(c[2 * m], c[2 * m + 1]);
        g[ch] = v;
    }
}

// Γ_c(P) = ∫ w_c(λ)/(λ − P) dλ, Im P > 0, from the tables (lutbake.spectral.poles.CauchyTable).
inline void cauchy_gamma(CPLX P, CAUCHY_ARGS, CPLX g[3]) {
    if (P.y < CAUCHY_SHALLOW) {
        const int j = (int)floor(P.x);
        horner3(cauchy_shallow + (j - CAUCHY_RE_MIN) * 6 * (SHALLOW_DEGREE + 1), SHALLOW_DEGREE,
                P - (CPLX)((REAL)j + (REAL)0.5, 0), g);
        for (int k = max(j + 1 - CAUCHY_NEAR_KNOTS, KNOT_MIN); k <= min(j + CAUCHY_NEAR_KNOTS, KNOT_MIN + N_KNOTS - 1);
             ++k) {
            const CPLX lg = c_log((CPLX)((REAL)k - P.x, -P.y));
            for (int ch = 0; ch < 3; ++ch) {
                const REAL a = cauchy_knots[ch * N_KNOTS + k - KNOT_MIN];
                const REAL b = cauchy_knots[(3 + ch) * N_KNOTS + k - KNOT_MIN];
                g[ch] += c_mul((CPLX)(a + b * P.x, b * P.y), lg);
            }
        }
        return;
    }
    int level = clamp((int)floor(log2(P.y / CAUCHY_SHALLOW)), 0, DEEP_LEVELS - 1);
    int first = 0;
    for (int l = 0; l < level; ++l) first += 2 * (int)ceil((CAUCHY_RE_MAX - CAUCHY_RE_MIN) / ((REAL)0.5 * CAUCHY_SHALLOW * (REAL)(1 << l)));
    const REAL depth = CAUCHY_SHALLOW * (REAL)(1 << level), width = (REAL)0.5 * depth;
    const int cols = (int)ceil((CAUCHY_RE_MAX - CAUCHY_RE_MIN) / width);
    const int row = P.y >= (REAL)1.5 * depth;
    const int col = clamp((int)floor((P.x - CAUCHY_RE_MIN) / width), 0, cols - 1);
    const CPLX centre = (CPLX)(CAUCHY_RE_MIN + ((REAL)col + (REAL)0.5) * width, depth * ((REAL)1.25 + (REAL)0.5 * row));
    horner3(cauchy_deep + (first + row * cols + col) * 6 * (DEEP_DEGREE + 1), DEEP_DEGREE, P - centre, g);
}

// A polarization's poles: the near ones (position, residue) and the bound M on |h| over E_BOUND_RHO.
typedef struct { CPLX P[MAX_NEAR]; CPLX R[MAX_NEAR]; int count; CPLX kq, reference; REAL x, M, residues, log_q_abs; } Poles;

// Enumerate the poles with Re p_n in the window (lutbake.spectral.poles.closed_form): 0 where more than
// MAX_NEAR are near or the window holds more than MAX_WINDOW (the texel goes to the direct quadrature).
inline int find_poles(CPLX k, CPLX q, REAL x, Poles *s) {
    const CPLX lq = c_log(q);
    const CPLX zeta = c_scale((CPLX)(-lq.y, lq.x), 1 / (2 * PI_R * x));
    const REAL n_lo = floor(x * (WINDOW_LO - zeta.x)), n_hi = ceil(x * (WINDOW_HI - zeta.x));
    if (n_hi - n_lo + 1 > MAX_WINDOW) return 0;
    s->kq = c_div(k, q);
    s->x = x;
    s->log_q_abs = lq.x;
    s->count = 0;
    s->residues = 0;
    REAL explicit_far = 0, best = INFINITY;
    const REAL to_residue = 1 / (2 * PI_R * x);
    for (REAL n = n_lo; n <= n_hi; n += 1) {
        const CPLX p = zeta + (CPLX)(n / x, 0);
        const CPLX P = c_recip(p);
        const CPLX P2 = c_mul(P, P);
        // R = (K/q) P²/(i2πX) = −i (K/q) P²/(2πX)
        const CPLX kp2 = c_mul(s->kq, P2);
        const CPLX R = c_scale((CPLX)(kp2.y, -kp2.x), to_residue);
        const REAL rho = bernstein_rho(P);
        const REAL off_centre = fabs(p.x - (REAL)1 / BAND_CENTRE);
        if (off_centre < best) { best = off_centre; s->reference = P; }
        if (rho < NEAR_RHO) {
            if (s->count == MAX_NEAR) return 0;
            s->P[s->count] = P;
            s->R[s->count] = R;
            s->residues += length(R);
            ++s->count;
        } else {
            explicit_far += length(R) / (semi_major(rho) - semi_major(BOUND_RHO));
        }
    }
    // the far tail (lutbake.spectral.poles._far_tail) and K/(1 − q)
    const REAL tail = length(s->kq) / (2 * PI_R * x * (REAL)129) * 2 * ((REAL)1 / ((REAL)2e-3 * (REAL)2e-3) + x / (REAL)2e-3);
    s->M = length(c_div(k, (CPLX)(1 - q.x, -q.y))) + explicit_far + tail;
    return 1;
}

// The a-priori bound on |ΔI_c| (largest channel): the Chebyshev rule's and the table's.
inline REAL poles_bound(const Poles *s, REAL gamma_bound, REAL weight_mass) {
    return weight_mass * 4 * s->M * pow(BOUND_RHO, -(REAL)(CHEB_NODES - 1)) / (BOUND_RHO - 1) + s->residues * gamma_bound;
}

// e^a − 1 given e^{a0} − 1 (em0) at a near a0: e^a − 1 = em0 + e^{a0} (e^δ − 1), δ = a − a0, with
// e^δ − 1 = δ (1 + δ/2 + …) taken as δ while |δ| ≤ 2^−26 min(1, |a0|) (then δ²/2 is below the rounding of
// e^a − 1), else expm1(a). Re x at the Chebyshev nodes is log|q| (|q z| = |q| on the real axis), the same
// a0 for a polarization's every node up to the rounding of θ, so this replaces 41 expm1 calls by one
// (~18% of the closed form's CPU on PoCL: docs/spectral.md).
inline REAL expm1_near(REAL a, REAL a0, REAL em0) {
    const REAL delta = a - a0;
    return fabs(delta) <= (REAL)0x1p-26 * fmin((REAL)1, fabs(a0)) ? em0 + (em0 + 1) * delta : expm1(a);
}

// 1/(e^x − 1) − 1/x, smooth at x = 0 (Bernoulli series there); em0 = e^{a0} − 1 for Re x near a0
// (expm1_near).
inline CPLX expm1_inverse_minus_pole(CPLX x, REAL a0, REAL em0) {
    if (length(x) < (REAL)0.05) {
        const CPLX x2 = c_mul(x, x);
        CPLX s = (CPLX)((REAL)-1 / (REAL)1209600, 0);
        s = c_mul(s, x2) + (CPLX)((REAL)1 / (REAL)30240, 0);
        s = c_mul(s, x2) + (CPLX)((REAL)-1 / (REAL)720, 0);
        s = c_mul(s, x2) + (CPLX)((REAL)1 / (REAL)12, 0);
        return c_mul(s, x) + (CPLX)((REAL)-0.5, 0);
    }
    // e^x − 1 = (e^a − 1) − 2 e^a sin²(b/2) + 2i e^a sin(b/2) cos(b/2), x = a + ib: no cancellation
    REAL c_half, s_half = sincos((REAL)0.5 * x.y, &c_half);
    const REAL em = expm1_near(x.x, a0, em0), e = em + 1;
    const CPLX em1 = (CPLX)(em - 2 * e * s_half * s_half, 2 * e * s_half * c_half);
    return c_recip(em1) - c_recip(x);
}

// I_c of one polarization (its poles found), added to out[3].
inline void poles_integral(const Poles *s, CAUCHY_ARGS, CPLX out[3]) {
    for (int j = 0; j < s->count; ++j) {
        CPLX g[3];
        cauchy_gamma(s->P[j], CAUCHY_PASS, g);
        for (int ch = 0; ch < 3; ++ch) out[ch] += c_mul(s->R[j], g[ch]);
    }
    const CPLX pole_scale = (CPLX)(0, -1 / (2 * PI_R * s->x));   // 1/(i2πX)
    const REAL em0 = expm1(s->log_q_abs);                          // e^{Re x} − 1 at every node (expm1_near)
    for (int i = 0; i < CHEB_NODES; ++i) {
        const REAL lam = cheb[i];
        int star = -1;
        REAL best = INFINITY;
        for (int j = 0; j < s->count; ++j) {
            const REAL d = c_abs2(s->P[j] - (CPLX)(lam, 0));
            if (d < best) { best = d; star = j; }
        }
        // q z = e^{iθ}, θ = 2πX (P* − λ)/(λ P*): f relative to the nearest pole, no rounding amplified
        const CPLX ps = star >= 0 ? s->P[star] : s->reference;
        const CPLX theta = c_scale(c_div(ps - (CPLX)(lam, 0), c_scale(ps, lam)), 2 * PI_R * s->x);
        const CPLX ix = (CPLX)(-theta.y, theta.x);
        CPLX h = (CPLX)(-1, 0) - expm1_inverse_minus_pole(ix, s->log_q_abs, em0);
        h += star >= 0 ? c_mul(ps, pole_scale) : -c_recip(ix);
        h = c_mul(s->kq, h);
        for (int j = 0; j < s->count; ++j)
            if (j != star) h -= c_div(s->R[j], (CPLX)(lam, 0) - s->P[j]);
        for (int ch = 0; ch < 3; ++ch) out[ch] += c_scale(h, cheb[CHEB_NODES * (1 + ch) + i]);
    }
}

// The plan's first pass over a band: for each texel the series takes, its bound (else 0) in `bound_out`
// and each (cos θ, D) pair's pair_terms raised to at least its terms; the rest appended to `rest` for
// plan_texels_closed. No work-group reduction here: a barrier halved this pass's speed on a CPU runtime
// (max_chunks reduces the bounds).
__kernel void plan_rows(const int n_cos, const int n_opd, const int width, const int row0, SERIES_ARGS,
                        __global int *pair_terms, __global int *rest, __global int *rest_count,
                        __global REAL *bound_out, const int n_items)
{
    ITEMS_GUARD
    BAND_TEXEL
    bound_out[gid] = 0;
    if (cap < 0) {
        rest[atomic_inc(rest_count)] = index;
        return;
    }
    const int terms = series_terms_bound(column, f[0], cap);
    if (terms > pair_terms[pair]) atomic_max(pair_terms + pair, terms);   // a read spares most atomics
    bound_out[gid] = bound;
}

// The largest of each `chunk` consecutive values (count of them in all).
__kernel void max_chunks(__global const REAL *values, const int count, const int chunk, __global REAL *out,
                         const int n_items)
{
    ITEMS_GUARD
    REAL m = 0;
    for (int i = gid * chunk; i < min(count, (gid + 1) * chunk); ++i) m = fmax(m, values[i]);
    out[gid] = m;
}

#ifdef LUTBAKE_FP64
// The closed form at one texel: 1 with the bound it enforces (both polarizations) in *bound and, where
// `integrate`, its colour in rgb[3]; 0 where it goes to the direct quadrature (out of scope, too many near
// poles, a bound above tol). The plan and the bake both run this: the same texel gives the same bits.
inline int closed_form_texel(const SeriesPol sp, const SeriesPol pp, const REAL x, __global const REAL *table,
                             CAUCHY_ARGS, const REAL tol, const int integrate, REAL *bound, REAL rgb[3]) {
    CPLX acc[3] = {(CPLX)(0, 0), (CPLX)(0, 0), (CPLX)(0, 0)};
    Poles poles;
    if (sp.one_minus_q < 0 || !find_poles(sp.k, sp.q, x, &poles)) return 0;
    const REAL bs = poles_bound(&poles, gamma_bound, weight_mass);
    if (bs > tol) return 0;
    if (integrate) poles_integral(&poles, CAUCHY_PASS, acc);
    if (!find_poles(pp.k, pp.q, x, &poles)) return 0;
    const REAL bp = poles_bound(&poles, gamma_bound, weight_mass);
    if (bp > tol) return 0;
    if (integrate) poles_integral(&poles, CAUCHY_PASS, acc);
    *bound = bs + bp;
    const REAL c0 = (REAL)0.5 * (sp.c0 + pp.c0);
    for (int c = 0; c < 3; ++c) rgb[c] = c0 * table[12 * c] + acc[c].x;
    return 1;
}
#endif

// The plan's second pass: at the texels the series left (`texel_count` of them in `texels`), the path
// (1 closed form, 2 direct), the closed form's bound and, where `integrate`, its colour (rgb_out, 3 per
// list entry), so that the bake need not search the poles again. float32 programs send every such texel
// to the direct path.
__kernel void plan_texels_closed(const int n_cos, const int n_opd, const int width, const int row0, SERIES_ARGS,
                                 CAUCHY_ARGS, __global const int *texels, __global const int *texel_count,
                                 const int integrate, __global char *path_out, __global REAL *bound_out,
                                 __global REAL *rgb_out, const int n_items)
{
    ITEMS_GUARD
    if (gid >= *texel_count) return;
    const int index = texels[gid];
    SERIES_TEXEL(index)
    path_out[gid] = 2;
    bound_out[gid] = 0;
#ifdef LUTBAKE_FP64
    REAL closed_bound, rgb[3];
    if (!closed_form_texel(sp, pp, f[0], table, CAUCHY_PASS, tol, integrate, &closed_bound, rgb)) return;
    path_out[gid] = 1;
    bound_out[gid] = closed_bound;
    if (integrate)
        for (int c = 0; c < 3; ++c) rgb_out[3 * gid + c] = rgb[c];
#endif
}

// The bake's second pass where the plan kept no colours: the closed form at the texels the series left
// (`texels`, `texel_count` of them, read here so that the host need not wait for the first pass); those it
// cannot take are appended to `rest` for the direct quadrature. Only the float64 program integrates;
// float32 passes every texel on.
__kernel void bake_texels_closed(const int n_cos, const int n_opd, const int width, const int row0, SERIES_ARGS,
                                 CAUCHY_ARGS, __global const int *texels, __global const int *texel_count,
                                 __global REAL *rgb_out, __global int *rest, __global int *rest_count, const int n_items)
{
    ITEMS_GUARD
    if (gid >= *texel_count) return;
    const int index = texels[gid];
    SERIES_TEXEL(index)
#ifdef LUTBAKE_FP64
    REAL closed_bound, rgb[3];
    if (cap < 0 && closed_form_texel(sp, pp, f[0], table, CAUCHY_PASS, tol, 1, &closed_bound, rgb)) {
        for (int c = 0; c < 3; ++c) rgb_out[3 * index + c] = rgb[c];
        return;
    }
#endif
    rest[atomic_inc(rest_count)] = index;
}

// Colours computed ahead (the plan's closed form) put at their texels of a band (`texels`, band indices).
__kernel void scatter_rgb(__global const int *texels, __global const REAL *rgb, __global REAL *rgb_out,
                          const int n_items)
{
    ITEMS_GUARD
    for (int c = 0; c < 3; ++c) rgb_out[3 * texels[gid] + c] = rgb[3 * gid + c];
}
