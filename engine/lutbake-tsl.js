// lutbake iridescence for three.js's WebGPURenderer (three r187's 'three/webgpu' and 'three/tsl', pinned in
// engine/package.json): the runtime table as a TSL node, and a drop-in that puts it in place of
// MeshPhysicalNodeMaterial's thin-film Fresnel term (three's evalIridescence, KHR_materials_iridescence).
// The material's parameters keep their meaning: iridescence, iridescenceIOR (the film's index),
// iridescenceThicknessMinimum/Maximum/Map (nm). The base under the film: the material's `ior` where it is dielectric;
// where it is metallic (metalness > 0) the per-channel n, k you pass as `metal` (lutbake's named metals at
// 611/549/464 nm: exact.base_rgb, docs/engines.md); the two terms are mixed by metalness, each evaluated only
// where its weight is non-zero.
//
//   import { loadLutbakeRuntimeNode, lutbakeNodeIridescence } from './lutbake-tsl.js';
//   const runtime = await loadLutbakeRuntimeNode('luts/runtime/lutbake-runtime');   // `lutbake runtime-table`
//   lutbakeNodeIridescence(material, { runtime });                                  // a MeshPhysicalNodeMaterial
//   lutbakeNodeIridescence(material, { runtime, metal: { eta: [0.27, 0.68, 1.32], kappa: [3.61, 2.63, 2.29] } });
//   // or the node alone, in any TSL graph: lutbakeIridescenceNode(runtime, cosTheta, thicknessNm, eta1, eta2, eta3, kappa3)
//   // (lutbakeIridescenceRgbNode: eta3, kappa3 per channel, vec3 nodes)
//
// One source of truth: the table's layout and constants are read from the GLSL include the table ships with
// (lutbake/shaders/runtime.glsl.in rendered by `lutbake runtime-table`); the arithmetic below is that include's,
// operation for operation (as lutbake/modes/runtime/model.py is in numpy), and the tests hold all three to 1e-4.
// `output` (tests, debugging): 'fresnel' writes the film's linear RGB Fresnel term instead of the lit colour,
// 'parameters' the (cos theta, thickness nm, film index) it used; with mode 'three' they are three.js's own.
import { DataTexture, HalfFloatType, RGBAFormat, LinearFilter, ClampToEdgeWrapping, PhysicalLightingModel, Vector3 } from 'three/webgpu';
import { If, float, vec2, vec3, vec4, property, texture, clamp, floor, fract, sqrt, max, min, mix, step, abs, length, dot, materialReference,
         iridescenceIOR, iridescenceThickness, ior, metalness, normalView, positionViewDirection, Schlick_to_F0 } from 'three/tsl';
import { loadRuntimeTable } from './lutbake-exr.js';

// The include's constants, by name (lutbake/shaders/runtime.glsl.in: `const highp float|vec2|vec3 NAME = ...;`).
const CONSTANTS = ['NU0', 'X_MAX', 'ZOOM', 'LAST_SLICE', 'HALF_SPAN', 'NODES', 'TILES', 'BAND', 'SIZE', 'WHITE'];

export function includeConstants(include, url) {
  const found = {};
  for (const [, name, value] of include.matchAll(/^const highp (?:float|vec2|vec3) LUTBAKE_RT_(\w+) = ([^;]+);/gm)) {
    const numbers = value.replace(/^vec[23]\(|\)$/g, '').split(',').map(Number);
    if (numbers.some((v) => !Number.isFinite(v))) throw new Error(`${url}: constant LUTBAKE_RT_${name} is not numeric: ${value}`);
    found[name] = numbers.length === 1 ? numbers[0] : numbers;
  }
  const missing = CONSTANTS.filter((name) => !(name in found));
  if (missing.length) throw new Error(`${url}: not a runtime-table include (no LUTBAKE_RT_${missing.join(', LUTBAKE_RT_')})`);
  return found;
}

// The runtime table as an RGBA half texture (bilinear, clamped, no mipmaps; scanline 0 at v = 0, as
// lutbake-exr.js returns it) and the include's constants.
export async function loadLutbakeRuntimeNode(stem) {
  const { width, height, texels, include, header } = await loadRuntimeTable(stem);
  const table = new DataTexture(texels, width, height, RGBAFormat, HalfFloatType);
  table.magFilter = table.minFilter = LinearFilter;
  table.wrapS = table.wrapT = ClampToEdgeWrapping;
  table.generateMipmaps = false;
  table.flipY = false;
  table.needsUpdate = true;
  const constants = includeConstants(include, stem);
  if (constants.SIZE[0] !== width || constants.SIZE[1] !== height) {
    throw new Error(`${stem}: the include is for a ${constants.SIZE.join(' x ')} table, the EXR is ${width} x ${height}`);
  }
  return { table, constants, hash: header['lutbake.content_hash'] };
}

const TWO_PI = 6.283185307179586;
const mul = (a, b) => vec2(a.x.mul(b.x).sub(a.y.mul(b.y)), a.x.mul(b.y).add(a.y.mul(b.x)));

// e^(2 pi i turns) - 1: polynomials about the nearest quarter turn k, rotated by i^k = (ck, sk) (lutbake_rt_cis_m1).
function cisM1(turns) {
  const k = floor(turns.mul(4).add(0.5));
  const x = turns.sub(k.mul(0.25)).mul(TWO_PI);
  const x2 = x.mul(x);
  const cm = x2.mul(float(-0.5).add(x2.mul(float(1 / 24).add(x2.mul(float(-1 / 720).add(x2.mul(1 / 40320)))))));
  const s = x.mul(float(1).add(x2.mul(float(-1 / 6).add(x2.mul(float(1 / 120).add(x2.mul(float(-1 / 5040).add(x2.mul(1 / 362880)))))))));
  const halfK = floor(k.mul(0.5));
  const odd = k.sub(halfK.mul(2));
  const sign = float(1).sub(halfK.sub(floor(halfK.mul(0.5)).mul(2)).mul(2));
  const ck = float(1).sub(odd).mul(sign), sk = odd.mul(sign);
  return vec2(ck.mul(cm).add(ck.sub(1)).sub(sk.mul(s)), sk.mul(cm).add(sk).add(ck.mul(s)));
}

// Principal square root for Im z >= 0 (lutbake_rt_sqrt).
function csqrt(z) {
  const h = sqrt(max(length(z).add(abs(z.x)).mul(0.5), 1e-30));
  const l = z.y.mul(0.5).div(h);
  const t = step(0.0, z.x);
  return vec2(t.mul(h).add(float(1).sub(t).mul(l)), t.mul(l).add(float(1).sub(t).mul(h)));
}

// One polarization: c0, f and the table coordinate w (lutbake_rt_pol; docs/spectral.md).
function polarization(y1, y2, p, q, em1, beta) {
  const inv = float(1).div(y1.add(y2));
  const a = y1.sub(y2).mul(inv);
  const ea = y1.mul(y2).mul(4).mul(inv).mul(inv);
  const pq = p.add(q);
  const n = float(1).div(dot(pq, pq));
  const at2 = vec2(dot(q, pq), q.y.mul(pq.x).sub(q.x.mul(pq.y))).mul(a.mul(2).mul(n));
  const eb = max(dot(p, q).mul(4).mul(n), 0.0);
  const eq = ea.div(max(ea.add(a.mul(a).mul(eb)), 1e-30));
  const c0 = a.mul(a).add(float(1).sub(eb).mul(ea).mul(eq));
  const zeta = vec2(y1.mul(2).mul(inv).sub(at2.x), at2.y.negate()).add(mul(vec2(a.sub(at2.x), at2.y.negate()), em1));
  const kr = eb.mul(eq);
  const kz = kr.div(max(dot(zeta, zeta), 1e-30));
  const f = vec2(kr.sub(kz.mul(zeta.x)), kz.mul(zeta.y));
  const num = vec2(beta.sub(zeta.x), zeta.y.negate());
  const den = vec2(beta.add(float(1).sub(beta).mul(zeta.x)), float(1).sub(beta).mul(zeta.y));
  const w = clamp(vec2(dot(num, den), num.y.mul(den.x).sub(num.x.mul(den.y))).div(max(dot(den, den), 1e-30)), -1.0, 1.0);
  return { c0, f, w };
}

// The film's part (lutbake_rt_film), scanline 0 at v = 0.
function film(c, cosTheta, thicknessNm, eta1, eta2) {
  const c1 = clamp(cosTheta, 0.0, 1.0);
  const e1c = eta1.mul(c1);
  const g2 = sqrt(max(eta2.sub(eta1).mul(eta2.add(eta1)).add(e1c.mul(e1c)), 1e-30));
  const x = thicknessNm.mul(2).mul(g2);
  const em1 = cisM1(fract(x.mul(c.NU0)));
  const beta = x.mul(2).div(x.mul(2).add(c.ZOOM));
  const s = sqrt(min(x.div(c.X_MAX), 1.0)).mul(c.LAST_SLICE);
  const j = min(floor(s), c.LAST_SLICE - 1);
  const row = floor(j.div(c.TILES));
  const centre = vec2(j.sub(row.mul(c.TILES)), row).add(0.5).mul(c.NODES).div(vec2(...c.SIZE));
  return { c1, g2, em1, beta, centre, xt: s.sub(j) };
}

// Both polarizations over base eta3 + i kappa3 (lutbake_rt_base).
function base(f, eta1, eta2, eta3, kappa3) {
  const e1c = eta1.mul(f.c1);
  const ek = eta3.mul(2).mul(kappa3);
  const g3 = csqrt(vec2(eta3.sub(eta1).mul(eta3.add(eta1)).sub(kappa3.mul(kappa3)).add(e1c.mul(e1c)), ek));
  const e22 = eta2.mul(eta2);
  const s = polarization(e1c, f.g2, vec2(f.g2, 0.0), g3, f.em1, f.beta);
  const p = polarization(e22.mul(f.c1), eta1.mul(f.g2), vec2(eta3.sub(kappa3).mul(eta3.add(kappa3)), ek).mul(f.g2),
    g3.mul(e22), f.em1, f.beta);
  return { c0: s.c0.add(p.c0).mul(0.5), s, p };
}

// V of channel `band` at table coordinate w, between the pair's slices (lutbake_rt_uv, lutbake_rt_read):
// one bilinear read at mip level 0 (valid in any control flow).
function read(runtime, f, w, band) {
  const c = runtime.constants;
  const uv = f.centre.add(w.mul(c.HALF_SPAN).div(vec2(...c.SIZE))).add(vec2(0, band * c.BAND / c.SIZE[1]));
  const v = texture(runtime.table, uv).level(0);
  return mix(v.xy, v.zw, f.xt);
}

// Channel `band`'s reflectance of one base's polarizations: (c0 + Re fs + Re fp) W + Re(f V) per polarization.
function channel(runtime, f, b, band) {
  const vs = read(runtime, f, b.s.w, band), vp = read(runtime, f, b.p.w, band);
  return b.c0.add(b.s.f.x).add(b.p.f.x).mul(runtime.constants.WHITE[band])
    .add(b.s.f.x.mul(vs.x)).sub(b.s.f.y.mul(vs.y)).add(b.p.f.x.mul(vp.x)).sub(b.p.f.y.mul(vp.y));
}

// Linear RGB reflectance of ambient eta1 | film eta2, thicknessNm | base eta3 + i kappa3, one base index
// (lutbake_iridescence); numbers or float nodes.
export function lutbakeIridescenceNode(runtime, cosTheta, thicknessNm, eta1, eta2, eta3, kappa3) {
  const f = film(runtime.constants, float(cosTheta), float(thicknessNm), float(eta1), float(eta2));
  const b = base(f, float(eta1), float(eta2), float(eta3), float(kappa3));
  return vec3(channel(runtime, f, b, 0), channel(runtime, f, b, 1), channel(runtime, f, b, 2));
}

// The same with one base index per channel, eta3 and kappa3 vec3 nodes (lutbake_iridescence_rgb: metals).
export function lutbakeIridescenceRgbNode(runtime, cosTheta, thicknessNm, eta1, eta2, eta3, kappa3) {
  const f = film(runtime.constants, float(cosTheta), float(thicknessNm), float(eta1), float(eta2));
  const channels = [[eta3.x, kappa3.x], [eta3.y, kappa3.y], [eta3.z, kappa3.z]];
  return vec3(...channels.map(([e, k], band) => channel(runtime, f, base(f, float(eta1), float(eta2), e, k), band)));
}

const OUTPUTS = { fresnel: 1, parameters: 2 };
// `output`'s value, written by the lighting model and read by the material's outputNode: that replaces
// three's output, which clamps colours at 0 (the term is negative where a film's colour is outside the gamut).
const OUTPUT = property('vec3', 'lutbakeOutput');

// MeshPhysicalNodeMaterial's lighting model with lutbake's term: start() computes it where three computes its
// evalIridescence, for the direct lights' BRDF and the multiple-scattering F0s alike; finish() writes
// `output`'s value.
class LutbakeLightingModel extends PhysicalLightingModel {
  constructor(flags, { runtime, mode, metal, output }) {
    super(...flags);
    Object.assign(this, { runtime, mode, metal, output });
  }

  start(builder) {
    if (this.iridescence !== true) return super.start(builder);
    const cosTheta = normalView.dot(positionViewDirection).clamp();
    this.lutbakeParameters = vec3(cosTheta, iridescenceThickness, iridescenceIOR);
    if (this.mode !== 'runtime') {
      super.start(builder);
      this.lutbakeFresnel = this.iridescenceFresnel;
      return undefined;
    }
    const args = [this.runtime, cosTheta, iridescenceThickness, 1.0, iridescenceIOR];
    const dielectric = vec3(0).toVar('lutbakeDielectric');
    const metallic = vec3(0).toVar('lutbakeMetallic');
    If(metalness.lessThan(1), () => { dielectric.assign(lutbakeIridescenceNode(...args, ior, 0.0)); });
    If(metalness.greaterThan(0), () => { metallic.assign(lutbakeIridescenceRgbNode(...args, this.metal.eta, this.metal.kappa)); });
    this.lutbakeFresnel = mix(dielectric, metallic, metalness).toVar('lutbakeFresnel');
    const terms = {
      iridescenceFresnel: this.lutbakeFresnel,
      iridescenceF0Dielectric: Schlick_to_F0({ f: dielectric, f90: 1.0, dotVH: cosTheta }),
      iridescenceF0Metallic: Schlick_to_F0({ f: metallic, f90: 1.0, dotVH: cosTheta }),
    };
    // The base class's start() assigns its own terms and then builds the lights and the multiple scattering
    // from them: these three hold lutbake's through it (three's evalIridescence nodes, never read, are not
    // emitted).
    for (const [name, value] of Object.entries(terms)) {
      Object.defineProperty(this, name, { get: () => value, set: () => {}, configurable: true, enumerable: true });
    }
    return super.start(builder);
  }

  finish(builder) {
    super.finish(builder);
    if (this.output && this.iridescence === true) {
      OUTPUT.assign(this.output === 'fresnel' ? this.lutbakeFresnel : this.lutbakeParameters);
    }
  }
}

const MODES = ['runtime', 'three'];
const DIELECTRIC_METAL = { eta: [1.5, 1.5, 1.5], kappa: [0, 0, 0] };

// Attach lutbake's term to a MeshPhysicalNodeMaterial (its iridescence must be > 0 to be used); returns it.
export function lutbakeNodeIridescence(material, { runtime = null, mode = runtime ? 'runtime' : 'three',
                                                   metal = DIELECTRIC_METAL, output = null } = {}) {
  if (!MODES.includes(mode)) throw new Error(`lutbakeNodeIridescence: mode '${mode}' is not one of ${MODES.join(', ')}`);
  if (mode === 'runtime' && !runtime) throw new Error("lutbakeNodeIridescence: mode 'runtime' needs the runtime node's table");
  if (output !== null && !(output in OUTPUTS)) throw new Error(`lutbakeNodeIridescence: output '${output}' is not fresnel or parameters`);
  if (!material.isMeshPhysicalNodeMaterial) throw new Error('lutbakeNodeIridescence: not a MeshPhysicalNodeMaterial');
  if (output) material.outputNode = vec4(OUTPUT, 1.0);
  // The metal is the material's (materials of one program share its nodes, not their values).
  material.lutbakeMetalEta = new Vector3(...metal.eta);
  material.lutbakeMetalKappa = new Vector3(...metal.kappa);
  const uniforms = { eta: materialReference('lutbakeMetalEta', 'vec3'), kappa: materialReference('lutbakeMetalKappa', 'vec3') };
  material.setupLightingModel = function setupLightingModel() {
    const flags = [this.useClearcoat, this.useSheen, this.useIridescence, this.useAnisotropy, this.useTransmission,
                   this.useDispersion, this.useRetroreflection, this.useDiffuseRoughness];
    return new LutbakeLightingModel(flags, { runtime, mode, metal: uniforms, output });
  };
  // Programs are shared between materials of one cache key, which three.js derives from the material's own
  // nodes: the lighting model and output are not among them.
  const key = `lutbake:${mode}:${output}:${runtime ? runtime.hash : ''}`;
  const base = material.customProgramCacheKey.bind(material);
  material.customProgramCacheKey = () => `${base()}|${key}`;
  material.needsUpdate = true;
  return material;
}
