// lutbake thin-film LUT sampler (HLSL) for lut-ab9defd7f35a.exr
// content hash 0e0610804679179c765d5184f436246de4371067b6e0ed43423eef36cc8d39a8; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Use a sampler with MIN_MAG_LINEAR filtering, CLAMP addressing and a single mip level.
// Axes in order (cos_theta, opd_nm, eta3, kappa3); opd_nm = 2 * eta2 * thickness_nm.

static const float4 LUTBAKE_MIN = float4(0.0, 480.0, 1.2, 0.5);
static const float4 LUTBAKE_MAX = float4(1.0, 1440.0, 2.8, 4.0);
static const float4 LUTBAKE_COUNT = float4(24.0, 32.0, 8.0, 16.0);
static const float4 LUTBAKE_SQRT = float4(1.0, 0.0, 0.0, 1.0); // 1: nodes uniform in sqrt(value)

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
float4 lutbake_node_coord(float4 v) {
    float4 w = lerp(v, sqrt(max(v, 0.0)), LUTBAKE_SQRT);
    float4 lo = lerp(LUTBAKE_MIN, sqrt(LUTBAKE_MIN), LUTBAKE_SQRT);
    float4 hi = lerp(LUTBAKE_MAX, sqrt(LUTBAKE_MAX), LUTBAKE_SQRT);
    return saturate((w - lo) / (hi - lo)) * (LUTBAKE_COUNT - 1.0);
}

// Linear RGB reflectance of the film stack: 4 bilinear fetches and 3 lerps.
float3 lutbake_sample(Texture2D<float3> lut, SamplerState linear_clamp,
                      float cos_theta, float opd_nm, float eta3, float kappa3) {
    float4 f = lutbake_node_coord(float4(cos_theta, opd_nm, eta3, kappa3));
    float2 tile = LUTBAKE_COUNT.xy;
    float2 size = tile * LUTBAKE_COUNT.zw;
    float2 base = min(floor(f.zw), LUTBAKE_COUNT.zw - 2.0);  // lower (eta3, kappa3) node
    float2 t = f.zw - base;
    float2 in_tile = f.xy + 0.5;                              // texel centres: no bleeding across tiles
    float3 c00 = lut.SampleLevel(linear_clamp, (base * tile + in_tile) / size, 0);
    float3 c10 = lut.SampleLevel(linear_clamp, ((base + float2(1.0, 0.0)) * tile + in_tile) / size, 0);
    float3 c01 = lut.SampleLevel(linear_clamp, ((base + float2(0.0, 1.0)) * tile + in_tile) / size, 0);
    float3 c11 = lut.SampleLevel(linear_clamp, ((base + float2(1.0, 1.0)) * tile + in_tile) / size, 0);
    return lerp(lerp(c00, c10, t.x), lerp(c01, c11, t.x), t.y);
}
