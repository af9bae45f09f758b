// lutbake scene material table for examples/ergun-table.toml (scene hash 8ac9cb30b3fc3741)
// Slices: sample the atlas with LINEAR filtering, CLAMP_TO_EDGE, no mipmaps.
const vec2 LUTBAKE_ATLAS_SIZE = vec2(16.0, 8.0);

// rect = (x0, y0, width, height) in texels; thick = (min, max) thickness in nm.
vec3 lutbake_atlas_sample(sampler2D atlas, vec4 rect, vec2 thick, float cos_theta, float thickness_nm) {
    float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (rect.z - 1.0);
    float fy = rect.w > 1.0 ? clamp((thickness_nm - thick.x) / max(thick.y - thick.x, 1e-9), 0.0, 1.0) * (rect.w - 1.0) : 0.0;
    return texture(atlas, (rect.xy + vec2(fx, fy) + 0.5) / LUTBAKE_ATLAS_SIZE).rgb;
}

const vec4 LUTBAKE_ERGUN_1_RECT = vec4(0.0, 0.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_1_THICKNESS = vec2(15.1667, 15.1667);
const vec4 LUTBAKE_ERGUN_2_RECT = vec4(0.0, 1.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_2_THICKNESS = vec2(158.333, 158.333);
const vec4 LUTBAKE_ERGUN_3_RECT = vec4(0.0, 2.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_3_THICKNESS = vec2(103.333, 103.333);
const vec4 LUTBAKE_ERGUN_4_RECT = vec4(0.0, 3.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_4_THICKNESS = vec2(109.541, 109.541);
const vec4 LUTBAKE_ERGUN_5_RECT = vec4(0.0, 4.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_5_THICKNESS = vec2(168.782, 168.782);
const vec4 LUTBAKE_ERGUN_6_RECT = vec4(0.0, 5.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_6_THICKNESS = vec2(284.916, 284.916);
const vec4 LUTBAKE_ERGUN_7_RECT = vec4(0.0, 6.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_7_THICKNESS = vec2(313.559, 313.559);
const vec4 LUTBAKE_ERGUN_8_RECT = vec4(0.0, 7.0, 16.0, 1.0);
const vec2 LUTBAKE_ERGUN_8_THICKNESS = vec2(289.34, 289.34);
