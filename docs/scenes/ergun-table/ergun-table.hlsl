// lutbake scene material table for examples/ergun-table.toml (scene hash 8ac9cb30b3fc3741)
// Slices: sample the atlas with MIN_MAG_LINEAR, CLAMP, one mip level.
static const float2 LUTBAKE_ATLAS_SIZE = float2(16.0, 8.0);

// rect = (x0, y0, width, height) in texels; thick = (min, max) thickness in nm.
float3 lutbake_atlas_sample(Texture2D<float3> atlas, SamplerState linear_clamp, float4 rect, float2 thick, float cos_theta, float thickness_nm) {
    float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (rect.z - 1.0);
    float fy = rect.w > 1.0 ? clamp((thickness_nm - thick.x) / max(thick.y - thick.x, 1e-9), 0.0, 1.0) * (rect.w - 1.0) : 0.0;
    return atlas.SampleLevel(linear_clamp, (rect.xy + float2(fx, fy) + 0.5) / LUTBAKE_ATLAS_SIZE, 0);
}

static const float4 LUTBAKE_ERGUN_1_RECT = float4(0.0, 0.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_1_THICKNESS = float2(15.1667, 15.1667);
static const float4 LUTBAKE_ERGUN_2_RECT = float4(0.0, 1.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_2_THICKNESS = float2(158.333, 158.333);
static const float4 LUTBAKE_ERGUN_3_RECT = float4(0.0, 2.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_3_THICKNESS = float2(103.333, 103.333);
static const float4 LUTBAKE_ERGUN_4_RECT = float4(0.0, 3.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_4_THICKNESS = float2(109.541, 109.541);
static const float4 LUTBAKE_ERGUN_5_RECT = float4(0.0, 4.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_5_THICKNESS = float2(168.782, 168.782);
static const float4 LUTBAKE_ERGUN_6_RECT = float4(0.0, 5.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_6_THICKNESS = float2(284.916, 284.916);
static const float4 LUTBAKE_ERGUN_7_RECT = float4(0.0, 6.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_7_THICKNESS = float2(313.559, 313.559);
static const float4 LUTBAKE_ERGUN_8_RECT = float4(0.0, 7.0, 16.0, 1.0);
static const float2 LUTBAKE_ERGUN_8_THICKNESS = float2(289.34, 289.34);
