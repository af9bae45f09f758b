// lutbake thin-film LUT sampler (GLSL: ES 3.00 / WebGL2, 3.30+, Vulkan) for lut-ab9defd7f35a.exr
// content hash 0e0610804679179c765d5184f436246de4371067b6e0ed43423eef36cc8d39a8; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Bind the LUT with LINEAR min/mag filtering, CLAMP_TO_EDGE wrapping and no mipmaps.
// Call: lutbake_sample(lut, LUTBAKE_LUT_AB9DEFD7F35A, cos_theta, opd_nm, eta3, kappa3), opd_nm = 2 * eta2 * thickness_nm.
// Row order (docs/lut-format.md): v = 0 is the EXR's last scanline, as OpenGL-style loaders (three.js's
// EXRLoader) upload it. If yours puts scanline 0 at v = 0, #define LUTBAKE_SCANLINE0_AT_V0 1 first.
// Several LUT includes and scene atlas includes can share one shader: the sampler is guarded, the
// constants are named per LUT.

#ifndef LUTBAKE_LUT_SAMPLER_V2
#define LUTBAKE_LUT_SAMPLER_V2
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 0
#endif

// Axes in order (cos_theta, opd_nm, eta3, kappa3); sqrt_spacing 1: nodes uniform in sqrt(value);
// eta3_admittance 1: eta3 nodes uniform in sqrt(eta3^2 - (eta1 sin theta1)^2) at the point's cos theta1.
struct LutbakeLut {
    highp vec4 lo;
    highp vec4 hi;
    highp vec4 count;
    highp vec4 sqrt_spacing;
    highp float eta3_admittance;
    highp float eta1;
    highp float eta2;
};

// Axis values in the coordinate their nodes are uniform in. ((v - eta1)(v + eta1) + (eta1 cos)^2 is
// v^2 - (eta1 sin theta1)^2 without cancellation near v = eta1 at grazing.)
highp vec4 lutbake_warp(LutbakeLut l, highp vec4 v, highp float cos_theta) {
    highp vec4 w = mix(v, sqrt(max(v, 0.0)), l.sqrt_spacing);
    highp float e1c = l.eta1 * cos_theta;
    w.z = mix(w.z, sqrt(max((v.z - l.eta1) * (v.z + l.eta1) + e1c * e1c, 0.0)), l.eta3_admittance);
    return w;
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

// Linear RGB reflectance of the film stack: 4 bilinear fetches and 3 lerps.
highp vec3 lutbake_sample(highp sampler2D lut, LutbakeLut l, highp float cos_theta, highp float opd_nm,
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
#endif

// lut-ab9defd7f35a.exr: axis minima, maxima, node counts, sqrt spacing; eta3 admittance spacing; eta1; eta2.
const LutbakeLut LUTBAKE_LUT_AB9DEFD7F35A = LutbakeLut(
    vec4(0.0, 480.0, 1.2, 0.5), vec4(1.0, 1440.0, 2.8, 4.0),
    vec4(24.0, 32.0, 8.0, 16.0), vec4(1.0, 0.0, 0.0, 1.0), 0.0,
    1.0, 1.6);
