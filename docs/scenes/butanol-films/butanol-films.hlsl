// lutbake scene material table for examples/butanol-films.toml (scene hash a786d6c6b0cda1eb)
// Slices: sample the atlas with MIN_MAG_LINEAR, CLAMP, one mip level.
static const float2 LUTBAKE_ATLAS_SIZE = float2(32.0, 172.0);

// rect = (x0, y0, width, height) in texels; thick = (min, max) thickness in nm.
float3 lutbake_atlas_sample(Texture2D<float3> atlas, SamplerState linear_clamp, float4 rect, float2 thick, float cos_theta, float thickness_nm) {
    float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (rect.z - 1.0);
    float fy = rect.w > 1.0 ? clamp((thickness_nm - thick.x) / max(thick.y - thick.x, 1e-9), 0.0, 1.0) * (rect.w - 1.0) : 0.0;
    return atlas.SampleLevel(linear_clamp, (rect.xy + float2(fx, fy) + 0.5) / LUTBAKE_ATLAS_SIZE, 0);
}

static const float4 LUTBAKE_BUTANOL_ON_GLASS_RECT = float4(0.0, 0.0, 32.0, 43.0);
static const float2 LUTBAKE_BUTANOL_ON_GLASS_THICKNESS = float2(100.0, 600.0);
static const float4 LUTBAKE_BUTANOL_ON_SILVER_RECT = float4(0.0, 43.0, 32.0, 43.0);
static const float2 LUTBAKE_BUTANOL_ON_SILVER_THICKNESS = float2(100.0, 600.0);
static const float4 LUTBAKE_BUTANOL_ON_COPPER_RECT = float4(0.0, 86.0, 32.0, 86.0);
static const float2 LUTBAKE_BUTANOL_ON_COPPER_THICKNESS = float2(100.0, 600.0);
