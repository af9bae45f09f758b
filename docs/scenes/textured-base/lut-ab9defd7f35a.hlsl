// lutbake thin-film LUT sampler (HLSL) for lut-ab9defd7f35a.exr
// content hash 0e0610804679179c765d5184f436246de4371067b6e0ed43423eef36cc8d39a8; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Use a sampler with MIN_MAG_LINEAR filtering, CLAMP addressing and a single mip level.
// Call: lutbake_sample(lut, linear_clamp, LUTBAKE_LUT_AB9DEFD7F35A, cos_theta, opd_nm, eta3, kappa3),
// opd_nm = 2 * eta2 * thickness_nm.
// Row order (docs/lut-format.md): v = 0 is the EXR's scanline 0, as D3D-style loaders upload it. If yours
// puts the last scanline at v = 0 (OpenGL-style), #define LUTBAKE_SCANLINE0_AT_V0 0 first.
// Several LUT includes and scene atlas includes can share one shader: the sampler is guarded, the
// constants are named per LUT.

#ifndef LUTBAKE_LUT_SAMPLER_V2
#define LUTBAKE_LUT_SAMPLER_V2
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 1
#endif

// Axes in order (cos_theta, opd_nm, eta3, kappa3); sqrt_spacing 1: nodes uniform in sqrt(value);
// eta3_admittance 1: eta3 nodes uniform in sqrt(eta3^2 - (eta1 sin theta1)^2) at the point's cos theta1.
struct LutbakeLut {
    float4 lo;
    float4 hi;
    float4 count;
    float4 sqrt_spacing;
    float eta3_admittance;
    float eta1;
    float eta2;
};

// Axis values in the coordinate their nodes are uniform in. ((v - eta1)(v + eta1) + (eta1 cos)^2 is
// v^2 - (eta1 sin theta1)^2 without cancellation near v = eta1 at grazing.)
float4 lutbake_warp(LutbakeLut l, float4 v, float cos_theta) {
    float4 w = lerp(v, sqrt(max(v, 0.0)), l.sqrt_spacing);
    float e1c = l.eta1 * cos_theta;
    w.z = lerp(w.z, sqrt(max((v.z - l.eta1) * (v.z + l.eta1) + e1c * e1c, 0.0)), l.eta3_admittance);
    return w;
}

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
float4 lutbake_node_coord(LutbakeLut l, float4 v) {
    float c = saturate(v.x);
    float4 lo = lutbake_warp(l, l.lo, c);
    float4 hi = lutbake_warp(l, l.hi, c);
    return saturate((lutbake_warp(l, v, c) - lo) / (hi - lo)) * (l.count - 1.0);
}

// Texture coordinate of a texel-space position measured in scanlines from the top.
float2 lutbake_lut_uv(float2 texel, float2 size) {
    float2 uv = texel / size;
#if LUTBAKE_SCANLINE0_AT_V0
    return uv;
#else
    return float2(uv.x, 1.0 - uv.y);
#endif
}

// Linear RGB reflectance of the film stack: 4 bilinear fetches and 3 lerps.
float3 lutbake_sample(Texture2D<float3> lut, SamplerState linear_clamp, LutbakeLut l,
                      float cos_theta, float opd_nm, float eta3, float kappa3) {
    float4 f = lutbake_node_coord(l, float4(cos_theta, opd_nm, eta3, kappa3));
    float2 tile = l.count.xy;
    float2 size = tile * l.count.zw;
    float2 base = min(floor(f.zw), l.count.zw - 2.0);  // lower (eta3, kappa3) node
    float2 t = f.zw - base;
    float2 in_tile = f.xy + 0.5;                        // texel centres: no bleeding across tiles
    float3 c00 = lut.SampleLevel(linear_clamp, lutbake_lut_uv(base * tile + in_tile, size), 0);
    float3 c10 = lut.SampleLevel(linear_clamp, lutbake_lut_uv((base + float2(1.0, 0.0)) * tile + in_tile, size), 0);
    float3 c01 = lut.SampleLevel(linear_clamp, lutbake_lut_uv((base + float2(0.0, 1.0)) * tile + in_tile, size), 0);
    float3 c11 = lut.SampleLevel(linear_clamp, lutbake_lut_uv((base + float2(1.0, 1.0)) * tile + in_tile, size), 0);
    return lerp(lerp(c00, c10, t.x), lerp(c01, c11, t.x), t.y);
}
#endif

// lut-ab9defd7f35a.exr: axis minima, maxima, node counts, sqrt spacing; eta3 admittance spacing; eta1; eta2.
static const LutbakeLut LUTBAKE_LUT_AB9DEFD7F35A = {
    float4(0.0, 480.0, 1.2, 0.5), float4(1.0, 1440.0, 2.8, 4.0),
    float4(24.0, 32.0, 8.0, 16.0), float4(1.0, 0.0, 0.0, 1.0), 0.0,
    1.0, 1.6};
