// lutbake thin-film LUT sampler (GLSL: ES 3.00 / WebGL2, 3.30+, Vulkan) for lut-ab9defd7f35a.exr
// content hash 4c66a6fab8e7f2c94744c0f0ca8fe84a48d145bdfec02424d359cada4c20ed1f; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Bind the LUT with LINEAR min/mag filtering, CLAMP_TO_EDGE wrapping and no mipmaps.
// Call: lutbake_sample(lut, LUTBAKE_LUT_AB9DEFD7F35A, cos_theta, opd_nm, eta3, kappa3), opd_nm = 2 * eta2 * thickness_nm:
// cubic interpolation, as the LUT's header says (docs/lut-format.md#interpolation).
// lutbake_sample_cubic (256 texel reads) and lutbake_sample_linear (4 bilinear fetches) force one.
// Row order (docs/lut-format.md): v = 0 is the EXR's last scanline, as OpenGL-style loaders (three.js's
// EXRLoader) upload it. If yours puts scanline 0 at v = 0, #define LUTBAKE_SCANLINE0_AT_V0 1 first.
// Several LUT includes and scene atlas includes can share one shader: the sampler is guarded, the
// constants are named per LUT.

#ifndef LUTBAKE_LUT_SAMPLER_V4
#define LUTBAKE_LUT_SAMPLER_V4
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 0
#endif

// Axes in order (cos_theta, opd_nm, eta3, kappa3); sqrt_spacing 1: nodes uniform in sqrt(value);
// root4_spacing 1: uniform in value^(1/4); mirror_low 1: the cubic rule mirrors node 1 below node 0;
// eta3_admittance 1: eta3 is first mapped to its admittance sqrt(eta3^2 - (eta1 sin theta1)^2) at the
// point's cos theta1, then warped like any axis: nodes uniform in the admittance ("admittance") or, with
// sqrt_spacing.z 1, in its square root ("sqrt-admittance").
struct LutbakeLut {
    highp vec4 lo;
    highp vec4 hi;
    highp vec4 count;
    highp vec4 sqrt_spacing;
    highp vec4 root4_spacing;
    highp vec4 mirror_low;
    highp float eta3_admittance;
    highp float eta1;
    highp float eta2;
    highp float cubic;  // 1: the header's interpolation is cubic
};

// Axis values in the coordinate their nodes are uniform in. ((v - eta1)(v + eta1) + (eta1 cos)^2 is
// v^2 - (eta1 sin theta1)^2 without cancellation near v = eta1 at grazing.)
highp vec4 lutbake_warp(LutbakeLut l, highp vec4 v, highp float cos_theta) {
    highp float e1c = l.eta1 * cos_theta;
    v.z = mix(v.z, sqrt(max((v.z - l.eta1) * (v.z + l.eta1) + e1c * e1c, 0.0)), l.eta3_admittance);
    highp vec4 w = mix(v, sqrt(max(v, 0.0)), l.sqrt_spacing);
    return mix(w, sqrt(sqrt(max(v, 0.0))), l.root4_spacing);
}

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
highp vec4 lutbake_node_coord(LutbakeLut l, highp vec4 v) {
    highp float c = clamp(v.x, 0.0, 1.0);
    highp vec4 lo = lutbake_warp(l, l.lo, c);
    highp vec4 hi = lutbake_warp(l, l.hi, c);
    return clamp((lutbake_warp(l, v, c) - lo) / (hi - lo), 0.0, 1.0) * (l.count - 1.0);
}

// Texture coordinate of a texel-space position measured in scanlines from the top.
highp vec2 lutbake_lut_uv(highp vec2 texel, highp vec2 size) {
    highp vec2 uv = texel / size;
#if LUTBAKE_SCANLINE0_AT_V0
    return uv;
#else
    return vec2(uv.x, 1.0 - uv.y);
#endif
}

// Linear RGB reflectance of the film stack, linear interpolation: 4 bilinear fetches and 3 lerps.
highp vec3 lutbake_sample_linear(highp sampler2D lut, LutbakeLut l, highp float cos_theta, highp float opd_nm,
                          highp float eta3, highp float kappa3) {
    highp vec4 f = lutbake_node_coord(l, vec4(cos_theta, opd_nm, eta3, kappa3));
    highp vec2 tile = l.count.xy;
    highp vec2 size = tile * l.count.zw;
    highp vec2 base = min(floor(f.zw), l.count.zw - 2.0);   // lower (eta3, kappa3) node
    highp vec2 t = f.zw - base;
    highp vec2 in_tile = f.xy + 0.5;                         // texel centres: no bleeding across tiles
    highp vec3 c00 = texture(lut, lutbake_lut_uv(base * tile + in_tile, size)).rgb;
    highp vec3 c10 = texture(lut, lutbake_lut_uv((base + vec2(1.0, 0.0)) * tile + in_tile, size)).rgb;
    highp vec3 c01 = texture(lut, lutbake_lut_uv((base + vec2(0.0, 1.0)) * tile + in_tile, size)).rgb;
    highp vec3 c11 = texture(lut, lutbake_lut_uv((base + vec2(1.0, 1.0)) * tile + in_tile, size)).rgb;
    return mix(mix(c00, c10, t.x), mix(c01, c11, t.x), t.y);
}

// Catmull-Rom weights of one axis at node coordinate f (lutbake/interpolation.py): taps are nodes
// first .. first + 3. Past an end the ghost node folds onto real nodes: its mirror at the low end of a
// sqrt or root4 axis from 0 (mirror_low), else quadratic extrapolation. 2 nodes: linear.
highp vec4 lutbake_cubic_weights(highp float f, highp float count, bool mirror_low, out highp float first) {
    if (count < 2.5) {
        first = -1.0;
        return vec4(0.0, 1.0 - f, f, 0.0);
    }
    highp float lower = min(floor(f), count - 2.0);
    highp float t = f - lower;
    highp float t2 = t * t;
    highp float t3 = t2 * t;
    highp float below = 0.5 * (-t3 + 2.0 * t2 - t);
    highp float w0 = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
    highp float w1 = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
    highp float above = 0.5 * (t3 - t2);
    if (lower < 0.5) {
        first = 0.0;
        return mirror_low ? vec4(w0, w1 + below, above, 0.0)
                          : vec4(w0 + 3.0 * below, w1 - 3.0 * below, above + below, 0.0);
    }
    if (lower > count - 2.5) {
        first = count - 4.0;
        return vec4(0.0, below + above, w0 - 3.0 * above, w1 + 3.0 * above);
    }
    first = lower - 1.0;
    return vec4(below, w0, w1, above);
}

// The texel of grid node (i_cos, i_opd, i_eta3, i_kappa3), clamped to the grid; no filtering.
highp vec3 lutbake_texel(highp sampler2D lut, LutbakeLut l, highp vec4 node) {
    highp vec4 n = clamp(node, vec4(0.0), l.count - 1.0);
    ivec2 xy = ivec2(n.z * l.count.x + n.x, n.w * l.count.y + n.y);
#if !LUTBAKE_SCANLINE0_AT_V0
    xy.y = int(l.count.y * l.count.w) - 1 - xy.y;
#endif
    return texelFetch(lut, xy, 0).rgb;
}

// Linear RGB reflectance of the film stack, cubic interpolation: 4 x 4 x 4 x 4 texel reads, the sum
// clamped per channel to the range of the 256 texels read (no overshoot).
highp vec3 lutbake_sample_cubic(highp sampler2D lut, LutbakeLut l, highp float cos_theta, highp float opd_nm,
                                highp float eta3, highp float kappa3) {
    highp vec4 f = lutbake_node_coord(l, vec4(cos_theta, opd_nm, eta3, kappa3));
    bvec4 mirror = greaterThan(l.mirror_low, vec4(0.5));
    highp vec4 first;
    highp vec4 wc = lutbake_cubic_weights(f.x, l.count.x, mirror.x, first.x);
    highp vec4 wd = lutbake_cubic_weights(f.y, l.count.y, mirror.y, first.y);
    highp vec4 we = lutbake_cubic_weights(f.z, l.count.z, mirror.z, first.z);
    highp vec4 wk = lutbake_cubic_weights(f.w, l.count.w, mirror.w, first.w);
    highp vec3 sum = vec3(0.0);
    highp vec3 low = vec3(1e30);
    highp vec3 high = vec3(-1e30);
    for (int k = 0; k < 4; ++k) {
        for (int e = 0; e < 4; ++e) {
            highp float w_base = wk[k] * we[e];
            for (int d = 0; d < 4; ++d) {
                for (int c = 0; c < 4; ++c) {
                    highp vec3 texel = lutbake_texel(lut, l, first + vec4(float(c), float(d), float(e), float(k)));
                    sum += (w_base * wd[d] * wc[c]) * texel;
                    low = min(low, texel);
                    high = max(high, texel);
                }
            }
        }
    }
    return clamp(sum, low, high);
}

// Linear RGB reflectance of the film stack by the LUT's own interpolation rule.
highp vec3 lutbake_sample(highp sampler2D lut, LutbakeLut l, highp float cos_theta, highp float opd_nm,
                          highp float eta3, highp float kappa3) {
    return l.cubic > 0.5 ? lutbake_sample_cubic(lut, l, cos_theta, opd_nm, eta3, kappa3)
                         : lutbake_sample_linear(lut, l, cos_theta, opd_nm, eta3, kappa3);
}
#endif

// lut-ab9defd7f35a.exr: axis minima, maxima, node counts, sqrt and root4 spacing, mirror at the low end;
// eta3 admittance spacing; eta1; eta2; cubic.
const LutbakeLut LUTBAKE_LUT_AB9DEFD7F35A = LutbakeLut(
    vec4(0.0, 480.0, 1.2, 0.5), vec4(1.0, 1440.0, 2.8, 4.0),
    vec4(16.0, 24.0, 4.0, 6.0), vec4(1.0, 0.0, 0.0, 1.0), vec4(0.0, 0.0, 0.0, 0.0), vec4(1.0, 0.0, 0.0, 0.0), 0.0,
    1.0, 1.6, 1.0);
