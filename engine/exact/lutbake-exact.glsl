// lutbake exact thin-film reflectance (GLSL: ES 3.00 / WebGL2, 3.30+, Vulkan) for lutbake-exact.exr
// content hash d347f1bbe9cad148; linear rec709 RGB, observer cie1931.
// Bind lutbake-exact.exr as a float (or half) RGB texture; it is read with texelFetch only (no filtering needed).
// Call: lutbake_exact(table, cos_theta, thickness_nm, eta1, eta2, eta3, kappa3)            (one base index)
//       lutbake_exact_rgb(table, cos_theta, thickness_nm, eta1, eta2, eta3_rgb, kappa3_rgb) (per channel)
// It sums the Fourier series of the Airy reflectance (docs/spectral.md): stops when the bound on the
// dropped terms is <= LUTBAKE_EXACT_TOLERANCE, at LUTBAKE_EXACT_MAX_TERMS terms, or at the table's end
// (define either before this include to change it). Each term: 4 texel fetches, ~100 scalar operations.
// Needs a propagating film: eta2 >= eta1 sin(theta1) (always so for a film in air).
// Row order as for LUTs (docs/lut-format.md): v = 0 is the EXR's last scanline, as three.js's EXRLoader
// uploads it. If your loader puts scanline 0 at v = 0, #define LUTBAKE_SCANLINE0_AT_V0 1 first.

#ifndef LUTBAKE_EXACT_V1
#define LUTBAKE_EXACT_V1
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 0
#endif
#ifndef LUTBAKE_EXACT_TOLERANCE
#define LUTBAKE_EXACT_TOLERANCE 0.0001
#endif
#ifndef LUTBAKE_EXACT_MAX_TERMS
#define LUTBAKE_EXACT_MAX_TERMS 64
#endif

const highp float LUTBAKE_EXACT_STEP_NM = 2.0;
const highp float LUTBAKE_EXACT_X_MAX_NM = 65534.0;
const int LUTBAKE_EXACT_WIDTH = 2048;
const int LUTBAKE_EXACT_ROWS = 16;
const int LUTBAKE_EXACT_TEXELS = 32768;
const highp float LUTBAKE_EXACT_NU0 = 0.001991298527443106;
// sup over y >= x of |W(y)| <= min(MASS, (EDGE + VARIATION / (2 pi x)) / (2 pi x))
const highp float LUTBAKE_EXACT_MASS = 1.9672142215965671;
const highp float LUTBAKE_EXACT_EDGE = 0.370292999412945;
const highp float LUTBAKE_EXACT_VARIATION = 462401435.56539404;
const highp float LUTBAKE_EXACT_TWO_PI = 6.283185307179586;

// Per polarization and channel: R = C0 W(0) + 2 Re sum K q^(m-1) W(m X); geo = |K| / (1 - |q|).
struct LutbakeExactPol {
    highp vec3 c0;
    highp vec3 k_re;
    highp vec3 k_im;
    highp vec3 q_re;
    highp vec3 q_im;
    highp vec3 geo;
};

highp vec2 lutbake_cmul(highp vec2 a, highp vec2 b) { return vec2(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
highp vec2 lutbake_cdiv(highp vec2 a, highp vec2 b) { return vec2(a.x * b.x + a.y * b.y, a.y * b.x - a.x * b.y) / dot(b, b); }

// Principal square root of z with Im z >= 0 (no cancellation on either half-plane).
highp vec2 lutbake_csqrt(highp vec2 z) {
    highp float r = length(z);
    if (r == 0.0) return vec2(0.0);
    if (z.x >= 0.0) {
        highp float s = sqrt(0.5 * (r + z.x));
        return vec2(s, z.y / (2.0 * s));
    }
    highp float t = sqrt(0.5 * (r - z.x));
    return vec2(z.y / (2.0 * t), t);
}

// (cos, sin) of 2 pi turns to float rounding: GPUs' built-in sin/cos may be off by 2^-11 (Vulkan's limit).
highp vec2 lutbake_cis(highp float turns) {
    highp float quarter = floor(4.0 * turns + 0.5);
    highp float x = LUTBAKE_EXACT_TWO_PI * (turns - 0.25 * quarter);   // |x| <= pi/4
    highp float x2 = x * x;
    highp float c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0))));
    highp float s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0)))));
    int k = int(quarter - 4.0 * floor(0.25 * quarter));   // quadrant 0..3
    return k == 0 ? vec2(c, s) : k == 1 ? vec2(-s, c) : k == 2 ? vec2(-c, -s) : vec2(s, -c);
}

// Normal admittance n cos(theta) = sqrt(n^2 - eta1^2 sin^2) of a medium eta + i kappa.
highp vec2 lutbake_admittance(highp float eta, highp float kappa, highp float eta1, highp float cos1) {
    return lutbake_csqrt(vec2((eta - eta1) * (eta + eta1) - kappa * kappa + eta1 * eta1 * cos1 * cos1,
                              2.0 * eta * kappa));
}

// C0, K, q, |K|/(1 - |q|) of one polarization from the admittances (y1, y2 real; y3 complex):
// a = (y1 - y2)/(y1 + y2), b = (y2 - y3)/(y2 + y3), q = -a b, gamma = b (1 - a^2),
// 1 - |q|^2 = (1 - a^2) + a^2 (1 - |b|^2) as a sum of terms >= 0 (no cancellation as |q| -> 1).
void lutbake_exact_pol(highp float y1, highp float y2, highp vec2 y3, out highp float c0, out highp vec2 k,
                       out highp vec2 q, out highp float geo) {
    highp float s12 = y1 + y2;
    highp float a = (y1 - y2) / s12;
    highp vec2 s23 = vec2(y2, 0.0) + y3;
    highp vec2 b = lutbake_cdiv(vec2(y2, 0.0) - y3, s23);
    highp float one_a2 = 4.0 * y1 * y2 / (s12 * s12);
    highp float one_b2 = max(4.0 * y2 * y3.x / dot(s23, s23), 0.0);
    highp float one_q2 = one_a2 + a * a * one_b2;
    highp vec2 gamma = b * one_a2;
    highp float g2 = dot(gamma, gamma);
    highp float ratio = g2 > 0.0 ? g2 / one_q2 : 0.0;
    q = -a * b;
    c0 = a * a + ratio;
    k = gamma * a + q * ratio;
    geo = g2 > 0.0 ? length(k) * (1.0 + length(q)) / one_q2 : 0.0;
}

// Both polarizations for one base index; writes channel `c` of s and p.
void lutbake_exact_base(highp float cos1, highp float eta1, highp float eta2, highp float g2, highp float eta3,
                        highp float kappa3, int c, inout LutbakeExactPol s, inout LutbakeExactPol p) {
    highp vec2 g3 = lutbake_admittance(eta3, kappa3, eta1, cos1);
    highp vec2 n3 = vec2(eta3, kappa3);
    highp float c0; highp vec2 k; highp vec2 q; highp float geo;
    lutbake_exact_pol(eta1 * cos1, g2, g3, c0, k, q, geo);
    s.c0[c] = c0; s.k_re[c] = k.x; s.k_im[c] = k.y; s.q_re[c] = q.x; s.q_im[c] = q.y; s.geo[c] = geo;
    lutbake_exact_pol(cos1 / eta1, g2 / (eta2 * eta2), lutbake_cdiv(g3, lutbake_cmul(n3, n3)), c0, k, q, geo);
    p.c0[c] = c0; p.k_re[c] = k.x; p.k_im[c] = k.y; p.q_re[c] = q.x; p.q_im[c] = q.y; p.geo[c] = geo;
}

// Table texel i (real part if part = 0, imaginary if 1) for each channel.
highp vec3 lutbake_exact_texel(highp sampler2D table, int i, int part) {
    int row = i / LUTBAKE_EXACT_WIDTH + part * LUTBAKE_EXACT_ROWS;
#if !LUTBAKE_SCANLINE0_AT_V0
    row = 2 * LUTBAKE_EXACT_ROWS - 1 - row;
#endif
    return texelFetch(table, ivec2(i - (i / LUTBAKE_EXACT_WIDTH) * LUTBAKE_EXACT_WIDTH, row), 0).rgb;
}

// The series for a film of X = 2 eta2 d cos(theta2) (nm); s, p per channel.
highp vec3 lutbake_exact_series(highp sampler2D table, highp float x_nm, LutbakeExactPol s, LutbakeExactPol p) {
    highp vec3 w0 = lutbake_exact_texel(table, 0, 0);
    highp vec3 acc = vec3(0.0);
    if (x_nm <= 0.0) {   // X = 0: sum K q^(m-1) = K / (1 - q)
        for (int c = 0; c < 3; ++c) {
            acc[c] = (s.geo[c] > 0.0 ? lutbake_cdiv(vec2(s.k_re[c], s.k_im[c]), vec2(1.0 - s.q_re[c], -s.q_im[c])).x : 0.0)
                   + (p.geo[c] > 0.0 ? lutbake_cdiv(vec2(p.k_re[c], p.k_im[c]), vec2(1.0 - p.q_re[c], -p.q_im[c])).x : 0.0);
        }
        return 0.5 * (s.c0 + p.c0) * w0 + acc * w0;
    }
    // W(m X) = f(m X) e^(i theta m): fold e^(i theta) into K and q, so no trigonometry per term.
    highp vec2 e = lutbake_cis(fract(LUTBAKE_EXACT_NU0 * x_nm));
    highp vec3 e_re = vec3(e.x), e_im = vec3(e.y);
    highp vec3 ps_re = s.k_re * e_re - s.k_im * e_im, ps_im = s.k_re * e_im + s.k_im * e_re;
    highp vec3 pp_re = p.k_re * e_re - p.k_im * e_im, pp_im = p.k_re * e_im + p.k_im * e_re;
    highp vec3 qs_re = s.q_re * e_re - s.q_im * e_im, qs_im = s.q_re * e_im + s.q_im * e_re;
    highp vec3 qp_re = p.q_re * e_re - p.q_im * e_im, qp_im = p.q_re * e_im + p.q_im * e_re;
    highp vec3 qs_abs = sqrt(s.q_re * s.q_re + s.q_im * s.q_im), qp_abs = sqrt(p.q_re * p.q_re + p.q_im * p.q_im);
    highp vec3 run = s.geo + p.geo;   // sum over polarizations of |K| |q|^M / (1 - |q|), per channel
    highp vec3 run_s = s.geo, run_p = p.geo;
    for (int m = 1; m <= LUTBAKE_EXACT_MAX_TERMS; ++m) {
        highp float xm = float(m) * x_nm;
        highp float w = LUTBAKE_EXACT_TWO_PI * xm;
        highp float tail = min(LUTBAKE_EXACT_MASS, (LUTBAKE_EXACT_EDGE + LUTBAKE_EXACT_VARIATION / w) / w);
        if (max(run.r, max(run.g, run.b)) * tail <= LUTBAKE_EXACT_TOLERANCE || xm > LUTBAKE_EXACT_X_MAX_NM) break;
        highp float u = xm / LUTBAKE_EXACT_STEP_NM;
        int i = min(int(u), LUTBAKE_EXACT_TEXELS - 2);
        highp float t = u - float(i);
        highp vec3 f_re = mix(lutbake_exact_texel(table, i, 0), lutbake_exact_texel(table, i + 1, 0), t);
        highp vec3 f_im = mix(lutbake_exact_texel(table, i, 1), lutbake_exact_texel(table, i + 1, 1), t);
        acc += ps_re * f_re - ps_im * f_im + pp_re * f_re - pp_im * f_im;
        highp vec3 r = ps_re * qs_re - ps_im * qs_im;
        ps_im = ps_re * qs_im + ps_im * qs_re; ps_re = r;
        r = pp_re * qp_re - pp_im * qp_im;
        pp_im = pp_re * qp_im + pp_im * qp_re; pp_re = r;
        run_s *= qs_abs; run_p *= qp_abs; run = run_s + run_p;
    }
    return 0.5 * (s.c0 + p.c0) * w0 + acc;
}

// Linear RGB reflectance of ambient eta1 | film eta2, thickness_nm | base eta3 + i kappa3 per channel.
highp vec3 lutbake_exact_rgb(highp sampler2D table, highp float cos_theta, highp float thickness_nm, highp float eta1,
                             highp float eta2, highp vec3 eta3, highp vec3 kappa3) {
    highp float cos1 = clamp(cos_theta, 0.0, 1.0);
    highp float g2 = lutbake_admittance(eta2, 0.0, eta1, cos1).x;
    LutbakeExactPol s, p;
    for (int c = 0; c < 3; ++c) lutbake_exact_base(cos1, eta1, eta2, g2, eta3[c], kappa3[c], c, s, p);
    return lutbake_exact_series(table, 2.0 * thickness_nm * g2, s, p);
}

// The same with one base index for all channels (dielectrics, or a grey metal).
highp vec3 lutbake_exact(highp sampler2D table, highp float cos_theta, highp float thickness_nm, highp float eta1,
                         highp float eta2, highp float eta3, highp float kappa3) {
    highp float cos1 = clamp(cos_theta, 0.0, 1.0);
    highp float g2 = lutbake_admittance(eta2, 0.0, eta1, cos1).x;
    LutbakeExactPol s, p;
    lutbake_exact_base(cos1, eta1, eta2, g2, eta3, kappa3, 0, s, p);
    s = LutbakeExactPol(s.c0.rrr, s.k_re.rrr, s.k_im.rrr, s.q_re.rrr, s.q_im.rrr, s.geo.rrr);
    p = LutbakeExactPol(p.c0.rrr, p.k_re.rrr, p.k_im.rrr, p.q_re.rrr, p.q_im.rrr, p.geo.rrr);
    return lutbake_exact_series(table, 2.0 * thickness_nm * g2, s, p);
}
#endif
