// lutbake thin-film LUT sampler (GLSL) for lut-ab9defd7f35a.exr
// content hash 0e0610804679179c765d5184f436246de4371067b6e0ed43423eef36cc8d39a8; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Bind the LUT with LINEAR min/mag filtering, CLAMP_TO_EDGE wrapping and no mipmaps.
// Axes in order (cos_theta, opd_nm, eta3, kappa3); opd_nm = 2 * eta2 * thickness_nm.

const vec4 LUTBAKE_MIN = vec4(0.0, 480.0, 1.2, 0.5);
const vec4 LUTBAKE_MAX = vec4(1.0, 1440.0, 2.8, 4.0);
const vec4 LUTBAKE_COUNT = vec4(24.0, 32.0, 8.0, 16.0);
const vec4 LUTBAKE_SQRT = vec4(1.0, 0.0, 0.0, 1.0); // 1: nodes uniform in sqrt(value)

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
vec4 lutbake_node_coord(vec4 v) {
    vec4 w = mix(v, sqrt(max(v, 0.0)), LUTBAKE_SQRT);
    vec4 lo = mix(LUTBAKE_MIN, sqrt(LUTBAKE_MIN), LUTBAKE_SQRT);
    vec4 hi = mix(LUTBAKE_MAX, sqrt(LUTBAKE_MAX), LUTBAKE_SQRT);
    return clamp((w - lo) / (hi - lo), 0.0, 1.0) * (LUTBAKE_COUNT - 1.0);
}

// Linear RGB reflectance of the film stack: 4 bilinear fetches and 3 lerps.
vec3 lutbake_sample(sampler2D lut, float cos_theta, float opd_nm, float eta3, float kappa3) {
    vec4 f = lutbake_node_coord(vec4(cos_theta, opd_nm, eta3, kappa3));
    vec2 tile = LUTBAKE_COUNT.xy;
    vec2 size = tile * LUTBAKE_COUNT.zw;
    vec2 base = min(floor(f.zw), LUTBAKE_COUNT.zw - 2.0);   // lower (eta3, kappa3) node
    vec2 t = f.zw - base;
    vec2 in_tile = f.xy + 0.5;                               // texel centres: no bleeding across tiles
    vec3 c00 = texture(lut, (base * tile + in_tile) / size).rgb;
    vec3 c10 = texture(lut, ((base + vec2(1.0, 0.0)) * tile + in_tile) / size).rgb;
    vec3 c01 = texture(lut, ((base + vec2(0.0, 1.0)) * tile + in_tile) / size).rgb;
    vec3 c11 = texture(lut, ((base + vec2(1.0, 1.0)) * tile + in_tile) / size).rgb;
    return mix(mix(c00, c10, t.x), mix(c01, c11, t.x), t.y);
}
