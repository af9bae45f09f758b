// lutbake scene material table for examples/butanol-films.toml (scene hash a786d6c6b0cda1eb)
// Slices: sample the atlas with LINEAR filtering, CLAMP_TO_EDGE, no mipmaps.
const vec2 LUTBAKE_ATLAS_SIZE = vec2(32.0, 172.0);

// rect = (x0, y0, width, height) in texels; thick = (min, max) thickness in nm.
vec3 lutbake_atlas_sample(sampler2D atlas, vec4 rect, vec2 thick, float cos_theta, float thickness_nm) {
    float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (rect.z - 1.0);
    float fy = rect.w > 1.0 ? clamp((thickness_nm - thick.x) / max(thick.y - thick.x, 1e-9), 0.0, 1.0) * (rect.w - 1.0) : 0.0;
    return texture(atlas, (rect.xy + vec2(fx, fy) + 0.5) / LUTBAKE_ATLAS_SIZE).rgb;
}

const vec4 LUTBAKE_BUTANOL_ON_GLASS_RECT = vec4(0.0, 0.0, 32.0, 43.0);
const vec2 LUTBAKE_BUTANOL_ON_GLASS_THICKNESS = vec2(100.0, 600.0);
const vec4 LUTBAKE_BUTANOL_ON_SILVER_RECT = vec4(0.0, 43.0, 32.0, 43.0);
const vec2 LUTBAKE_BUTANOL_ON_SILVER_THICKNESS = vec2(100.0, 600.0);
const vec4 LUTBAKE_BUTANOL_ON_COPPER_RECT = vec4(0.0, 86.0, 32.0, 86.0);
const vec2 LUTBAKE_BUTANOL_ON_COPPER_THICKNESS = vec2(100.0, 600.0);
