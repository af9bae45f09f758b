// lutbake scene material table for examples/soap-bubble.toml (scene hash 87275fdbb3cef532)
// Slices: sample the atlas with MIN_MAG_LINEAR, CLAMP, one mip level.
static const float2 LUTBAKE_ATLAS_SIZE = float2(64.0, 73.0);

// rect = (x0, y0, width, height) in texels; thick = (min, max) thickness in nm.
float3 lutbake_atlas_sample(Texture2D<float3> atlas, SamplerState linear_clamp, float4 rect, float2 thick, float cos_theta, float thickness_nm) {
    float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (rect.z - 1.0);
    float fy = rect.w > 1.0 ? clamp((thickness_nm - thick.x) / max(thick.y - thick.x, 1e-9), 0.0, 1.0) * (rect.w - 1.0) : 0.0;
    return atlas.SampleLevel(linear_clamp, (rect.xy + float2(fx, fy) + 0.5) / LUTBAKE_ATLAS_SIZE, 0);
}

static const float4 LUTBAKE_SOAP_RECT = float4(0.0, 0.0, 64.0, 73.0);
static const float2 LUTBAKE_SOAP_THICKNESS = float2(100.0, 1000.0);
