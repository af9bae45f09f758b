// lutbake scene material table for oil-on-water.toml (scene hash b541a616bda903a7), atlas oil-on-water.exr
// Sample the atlas with LINEAR min/mag filtering, CLAMP_TO_EDGE wrapping and no mipmaps.
// Call: lutbake_atlas_sample(atlas, LUTBAKE_<SCENE>_<MATERIAL>, cos_theta, thickness_nm).
// Row order as for LUTs (docs/lut-format.md): v = 0 is the EXR's last scanline unless
// LUTBAKE_SCANLINE0_AT_V0 is defined to 1 first. Several includes can share one shader.

#ifndef LUTBAKE_ATLAS_SAMPLER_V1
#define LUTBAKE_ATLAS_SAMPLER_V1
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 0
#endif

// A material's slice: rect = (x0, y0, width, height) in texels from the top-left; cos theta runs along x
// (nodes uniform in sqrt(cos theta) over [0, 1]), thickness along y over [thickness_nm.x, thickness_nm.y].
struct LutbakeSlice {
    highp vec4 rect;
    highp vec2 thickness_nm;
    highp vec2 atlas_size;
};

highp vec3 lutbake_atlas_sample(highp sampler2D atlas, LutbakeSlice s, highp float cos_theta,
                                highp float thickness_nm) {
    highp float fx = clamp(sqrt(max(cos_theta, 0.0)), 0.0, 1.0) * (s.rect.z - 1.0);
    highp float fy = s.rect.w > 1.0
        ? clamp((thickness_nm - s.thickness_nm.x) / max(s.thickness_nm.y - s.thickness_nm.x, 1e-9), 0.0, 1.0)
          * (s.rect.w - 1.0)
        : 0.0;
    highp vec2 uv = (s.rect.xy + vec2(fx, fy) + 0.5) / s.atlas_size;  // texel centres: stays in the rect
#if !LUTBAKE_SCANLINE0_AT_V0
    uv.y = 1.0 - uv.y;
#endif
    return texture(atlas, uv).rgb;
}
#endif

const LutbakeSlice LUTBAKE_OIL_ON_WATER_OIL_SLICK = LutbakeSlice(vec4(0.0, 0.0, 24.0, 82.0), vec2(100.0, 1000.0), vec2(24.0, 82.0));
