// lutbake thin-film LUT sampler (HLSL) for lutbake-eta2-2.00.exr
// content hash f20a6d521b4fcfe4fbff5bf103a04b000d46ec0eb36552b970b0763060261ab7; film eta2 = 2.0 under ambient eta1 = 1.0; linear rec709 RGB.
// Use a sampler with MIN_MAG_LINEAR filtering, CLAMP addressing and a single mip level.
// Call: lutbake_sample(lut, linear_clamp, LUTBAKE_ETA2_2_00, cos_theta, opd_nm, eta3, kappa3),
// opd_nm = 2 * eta2 * thickness_nm.
// Row order (docs/lut-format.md): v = 0 is the EXR's scanline 0, as D3D-style loaders upload it. If yours
// puts the last scanline at v = 0 (OpenGL-style), #define LUTBAKE_SCANLINE0_AT_V0 0 first.
// Several LUT includes and scene atlas includes can share one shader: the sampler is guarded, the
// constants are named per LUT.

#ifndef LUTBAKE_LUT_SAMPLER_V1
#define LUTBAKE_LUT_SAMPLER_V1
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 1
#endif

// Axes in order (cos_theta, opd_nm, eta3, kappa3); sqrt_spacing 1: nodes uniform in sqrt(value).
struct LutbakeLut {
    float4 lo;
    float4 hi;
    float4 count;
    float4 sqrt_spacing;
    float eta1;
    float eta2;
};

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
float4 lutbake_node_coord(LutbakeLut l, float4 v) {
    float4 w = lerp(v, sqrt(max(v, 0.0)), l.sqrt_spacing);
    float4 lo = lerp(l.lo, sqrt(l.lo), l.sqrt_spacing);
    float4 hi = lerp(l.hi, sqrt(l.hi), l.sqrt_spacing);
    return saturate((w - lo) / (hi - lo)) * (l.count - 1.0);
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

// lutbake-eta2-2.00.exr: axis minima, maxima, node counts, sqrt spacing; eta1; eta2.
static const LutbakeLut LUTBAKE_ETA2_2_00 = {
    float4(0.0, 0.0, 1.0, 0.0), float4(1.0, 3000.0, 3.0, 5.0),
    float4(32.0, 128.0, 16.0, 16.0), float4(1.0, 0.0, 0.0, 1.0),
    1.0, 2.0};
