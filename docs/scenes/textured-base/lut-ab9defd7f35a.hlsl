// lutbake thin-film LUT sampler (HLSL) for lut-ab9defd7f35a.exr
// content hash 4c66a6fab8e7f2c94744c0f0ca8fe84a48d145bdfec02424d359cada4c20ed1f; film eta2 = 1.6 under ambient eta1 = 1.0; linear rec709 RGB.
// Use a sampler with MIN_MAG_LINEAR filtering, CLAMP addressing and a single mip level.
// Call: lutbake_sample(lut, linear_clamp, LUTBAKE_LUT_AB9DEFD7F35A, cos_theta, opd_nm, eta3, kappa3),
// opd_nm = 2 * eta2 * thickness_nm: cubic interpolation, as the LUT's header says
// (docs/lut-format.md#interpolation). lutbake_sample_cubic (256 texel reads) and lutbake_sample_linear
// (4 bilinear fetches) force one.
// Row order (docs/lut-format.md): v = 0 is the EXR's scanline 0, as D3D-style loaders upload it. If yours
// puts the last scanline at v = 0 (OpenGL-style), #define LUTBAKE_SCANLINE0_AT_V0 0 first.
// Several LUT includes and scene atlas includes can share one shader: the sampler is guarded, the
// constants are named per LUT.

#ifndef LUTBAKE_LUT_SAMPLER_V4
#define LUTBAKE_LUT_SAMPLER_V4
#ifndef LUTBAKE_SCANLINE0_AT_V0
#define LUTBAKE_SCANLINE0_AT_V0 1
#endif

// Axes in order (cos_theta, opd_nm, eta3, kappa3); sqrt_spacing 1: nodes uniform in sqrt(value);
// root4_spacing 1: uniform in value^(1/4); mirror_low 1: the cubic rule mirrors node 1 below node 0;
// eta3_admittance 1: eta3 is first mapped to its admittance sqrt(eta3^2 - (eta1 sin theta1)^2) at the
// point's cos theta1, then warped like any axis: nodes uniform in the admittance ("admittance") or, with
// sqrt_spacing.z 1, in its square root ("sqrt-admittance").
struct LutbakeLut {
    float4 lo;
    float4 hi;
    float4 count;
    float4 sqrt_spacing;
    float4 root4_spacing;
    float4 mirror_low;
    float eta3_admittance;
    float eta1;
    float eta2;
    float cubic;  // 1: the header's interpolation is cubic
};

// Axis values in the coordinate their nodes are uniform in. ((v - eta1)(v + eta1) + (eta1 cos)^2 is
// v^2 - (eta1 sin theta1)^2 without cancellation near v = eta1 at grazing.)
float4 lutbake_warp(LutbakeLut l, float4 v, float cos_theta) {
    float e1c = l.eta1 * cos_theta;
    v.z = lerp(v.z, sqrt(max((v.z - l.eta1) * (v.z + l.eta1) + e1c * e1c, 0.0)), l.eta3_admittance);
    float4 w = lerp(v, sqrt(max(v, 0.0)), l.sqrt_spacing);
    return lerp(w, sqrt(sqrt(max(v, 0.0))), l.root4_spacing);
}

// Continuous node coordinate in [0, count - 1] for each axis (clamped to the domain).
float4 lutbake_node_coord(LutbakeLut l, float4 v) {
    float c = saturate(v.x);
    float4 lo = lutbake_warp(l, l.lo, c);
    float4 hi = lutbake_warp(l, l.hi, c);
    return saturate((lutbake_warp(l, v, c) - lo) / (hi - lo)) * (l.count - 1.0);
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

// Linear RGB reflectance of the film stack, linear interpolation: 4 bilinear fetches and 3 lerps.
float3 lutbake_sample_linear(Texture2D<float3> lut, SamplerState linear_clamp, LutbakeLut l,
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

// Catmull-Rom weights of one axis at node coordinate f (lutbake/interpolation.py): taps are nodes
// first .. first + 3. Past an end the ghost node folds onto real nodes: its mirror at the low end of a
// sqrt or root4 axis from 0 (mirror_low), else quadratic extrapolation. 2 nodes: linear.
float4 lutbake_cubic_weights(float f, float count, bool mirror_low, out float first) {
    if (count < 2.5) {
        first = -1.0;
        return float4(0.0, 1.0 - f, f, 0.0);
    }
    float lower = min(floor(f), count - 2.0);
    float t = f - lower;
    float t2 = t * t;
    float t3 = t2 * t;
    float below = 0.5 * (-t3 + 2.0 * t2 - t);
    float w0 = 0.5 * (3.0 * t3 - 5.0 * t2 + 2.0);
    float w1 = 0.5 * (-3.0 * t3 + 4.0 * t2 + t);
    float above = 0.5 * (t3 - t2);
    if (lower < 0.5) {
        first = 0.0;
        return mirror_low ? float4(w0, w1 + below, above, 0.0)
                          : float4(w0 + 3.0 * below, w1 - 3.0 * below, above + below, 0.0);
    }
    if (lower > count - 2.5) {
        first = count - 4.0;
        return float4(0.0, below + above, w0 - 3.0 * above, w1 + 3.0 * above);
    }
    first = lower - 1.0;
    return float4(below, w0, w1, above);
}

// The texel of grid node (i_cos, i_opd, i_eta3, i_kappa3), clamped to the grid; no filtering.
float3 lutbake_texel(Texture2D<float3> lut, LutbakeLut l, float4 node) {
    float4 n = clamp(node, 0.0, l.count - 1.0);
    int2 xy = int2(n.z * l.count.x + n.x, n.w * l.count.y + n.y);
#if !LUTBAKE_SCANLINE0_AT_V0
    xy.y = int(l.count.y * l.count.w) - 1 - xy.y;
#endif
    return lut.Load(int3(xy, 0));
}

// Linear RGB reflectance of the film stack, cubic interpolation: 4 x 4 x 4 x 4 texel reads, the sum
// clamped per channel to the range of the 256 texels read (no overshoot).
float3 lutbake_sample_cubic(Texture2D<float3> lut, LutbakeLut l, float cos_theta, float opd_nm, float eta3,
                            float kappa3) {
    float4 f = lutbake_node_coord(l, float4(cos_theta, opd_nm, eta3, kappa3));
    bool4 mirror = l.mirror_low > 0.5;
    float4 first;
    float4 wc = lutbake_cubic_weights(f.x, l.count.x, mirror.x, first.x);
    float4 wd = lutbake_cubic_weights(f.y, l.count.y, mirror.y, first.y);
    float4 we = lutbake_cubic_weights(f.z, l.count.z, mirror.z, first.z);
    float4 wk = lutbake_cubic_weights(f.w, l.count.w, mirror.w, first.w);
    float3 sum = 0.0;
    float3 low = 1e30;
    float3 high = -1e30;
    for (int k = 0; k < 4; ++k) {
        for (int e = 0; e < 4; ++e) {
            float w_base = wk[k] * we[e];
            for (int d = 0; d < 4; ++d) {
                for (int c = 0; c < 4; ++c) {
                    float3 texel = lutbake_texel(lut, l, first + float4(c, d, e, k));
                    sum += (w_base * wd[d] * wc[c]) * texel;
                    low = min(low, texel);
                    high = max(high, texel);
                }
            }
        }
    }
    return clamp(sum, low, high);
}

// Linear RGB reflectance of the film stack by the LUT's own interpolation rule (the sampler state is
// used by the linear rule only).
float3 lutbake_sample(Texture2D<float3> lut, SamplerState linear_clamp, LutbakeLut l,
                      float cos_theta, float opd_nm, float eta3, float kappa3) {
    return l.cubic > 0.5 ? lutbake_sample_cubic(lut, l, cos_theta, opd_nm, eta3, kappa3)
                         : lutbake_sample_linear(lut, linear_clamp, l, cos_theta, opd_nm, eta3, kappa3);
}
#endif

// lut-ab9defd7f35a.exr: axis minima, maxima, node counts, sqrt and root4 spacing, mirror at the low end;
// eta3 admittance spacing; eta1; eta2; cubic.
static const LutbakeLut LUTBAKE_LUT_AB9DEFD7F35A = {
    float4(0.0, 480.0, 1.2, 0.5), float4(1.0, 1440.0, 2.8, 4.0),
    float4(16.0, 24.0, 4.0, 6.0), float4(1.0, 0.0, 0.0, 1.0), float4(0.0, 0.0, 0.0, 0.0), float4(1.0, 0.0, 0.0, 0.0), 0.0,
    1.0, 1.6, 1.0};
