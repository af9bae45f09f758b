// lutbake scene material table for ergun-table.toml (scene hash 8ac9cb30b3fc3741), atlas ergun-table.exr
// Use a sampler with MIN_MAG_LINEAR filtering, CLAMP addressing and a single mip level.
// Call: lutbake_atlas_sample(atlas, linear_clamp, LUTBAKE_<SCENE>_<MATERIAL>, cos_theta, thickness_nm).
// Row order as for LUTs (docs/lut-format.md): v = 0 is the EXR's scanline 0 unless
// LUTBAKE_SCANLINE0_AT_V0 is defined to 0 first. Several includes can share one shader.

#ifndef LUTBAKE_ATLAS_SAMPLER_V1
#define LUTBAKE_ATLAS_SAMPLER_V1
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 1
#endif

// A material's slice: rect = (x0, y0, width, height) in texels from the top-left; cos theta runs along x
// (nodes uniform in sqrt(cos theta) over [0, 1]), thickness along y over [thickness_nm.x, thickness_nm.y].
struct LutbakeSlice {
    float4 rect;
    float2 thickness_nm;
    float2 atlas_size;
};

float3 lutbake_atlas_sample(Texture2D<float3> atlas, SamplerState linear_clamp, LutbakeSlice s,
                            float cos_theta, float thickness_nm) {
    float fx = saturate(sqrt(max(cos_theta, 0.0))) * (s.rect.z - 1.0);
    float fy = s.rect.w > 1.0
        ? saturate((thickness_nm - s.thickness_nm.x) / max(s.thickness_nm.y - s.thickness_nm.x, 1e-9))
          * (s.rect.w - 1.0)
        : 0.0;
    float2 uv = (s.rect.xy + float2(fx, fy) + 0.5) / s.atlas_size;  // texel centres: stays in the rect
#if !LUTBAKE_SCANLINE0_AT_V0
    uv.y = 1.0 - uv.y;
#endif
    return atlas.SampleLevel(linear_clamp, uv, 0);
}
#endif

static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_1 = {float4(0.0, 0.0, 12.0, 1.0), float2(15.1667, 15.1667), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_2 = {float4(0.0, 1.0, 16.0, 1.0), float2(158.333, 158.333), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_3 = {float4(0.0, 2.0, 12.0, 1.0), float2(103.333, 103.333), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_4 = {float4(0.0, 3.0, 12.0, 1.0), float2(109.541, 109.541), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_5 = {float4(0.0, 4.0, 12.0, 1.0), float2(168.782, 168.782), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_6 = {float4(0.0, 5.0, 12.0, 1.0), float2(284.916, 284.916), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_7 = {float4(0.0, 6.0, 12.0, 1.0), float2(313.559, 313.559), float2(16.0, 8.0)};
static const LutbakeSlice LUTBAKE_ERGUN_TABLE_ERGUN_8 = {float4(0.0, 7.0, 12.0, 1.0), float2(289.34, 289.34), float2(16.0, 8.0)};
