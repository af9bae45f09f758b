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
// operation for operation (as lutbake/modes/runtime/model.py is in numpy): tests/engines/test_webgpu_engine.py holds
// the node to the model within float32 rounding of the same operations, and all three to 1e-4 (with three.js's WebGL).
// `output` (tests, debugging): 'fresnel' writes the film's linear RGB Fresnel term instead of the lit colour,
// 'parameters' the (cos theta, thickness nm, film index) it used; with mode 'three' they are three.js's own.
import { DataTexture, HalfFloatType, RGBAFormat, LinearFilter, ClampToEdgeWrapping, PhysicalLightingModel, Vector3 } from 'three/webgpu';
import { If, float, vec2, vec3, vec4, property, texture, clamp, floor, fract, sqrt, max, min, mix, select, abs, length, dot, materialReference,
         iridescenceIOR, iridescenceThickness, ior, metalness, normalView, positionViewDirection, Schlick_to_F0 } from 'three/tsl';
import { loadRuntimeTable } from './lutbake-exr.js';

// The include's constants, by name: its `const highp float|vec2|vec3 LUTBAKE_RT_NAME = ...;` lines and the texture
// units it derives from them as `#define LUTBAKE_RT_NAME expression` (evaluated here as the GLSL compiler folds
// them, with LUTBAKE_SCANLINE0_AT_V0 1: the table below has scanline 0 at v = 0).
const CONSTANTS = ['NU0', 'X_MAX', 'ZOOM', 'LAST_SLICE', 'HALF_SPAN', 'NODES', 'TILES', 'BAND', 'SIZE', 'WHITE'];
const MACROS = ['V', 'SCALE', 'REACH', 'TILE_STEP', 'TILE_ORIGIN', 'BAND_STEP'];
const FLAGS = { LUTBAKE_SCANLINE0_AT_V0: true };

export function includeConstants(include, url) {
  const found = {};
  for (const [, name, value] of include.matchAll(/^const highp (?:float|vec2|vec3) LUTBAKE_RT_(\w+) = ([^;]+);/gm)) {
    const numbers = value.replace(/^vec[23]\(|\)$/g, '').split(',').map(Number);
    if (numbers.some((v) => !Number.isFinite(v))) throw new Error(`${url}: constant LUTBAKE_RT_${name} is not numeric: ${value}`);
    found[name] = numbers.length === 1 ? numbers[0] : numbers;
  }
  for (const [name, expression] of activeDefines(include)) {
    try { found[name] = evaluate(expression, found); } catch (e) { throw new Error(`${url}: macro LUTBAKE_RT_${name}: ${e.message}`); }
  }
  const missing = [...CONSTANTS, ...MACROS].filter((name) => !(name in found));
  if (missing.length) throw new Error(`${url}: not a runtime-table include (no LUTBAKE_RT_${missing.join(', LUTBAKE_RT_')})`);
  return found;
}

// The `#define LUTBAKE_RT_NAME expression` lines the preprocessor keeps (`#if FLAG` by FLAGS; guards kept).
function* activeDefines(include) {
  const kept = [];
  for (const line of include.split('\n')) {
    const [, directive, flag] = line.match(/^#(if|ifdef|ifndef|else|endif)\b\s*(\w*)/) ?? [];
    if (directive === 'if') kept.push(FLAGS[flag] === true);
    else if (directive === 'ifdef' || directive === 'ifndef') kept.push(true);
    else if (directive === 'else') kept.push(!kept.pop());
    else if (directive === 'endif') kept.pop();
    const define = line.match(/^#define LUTBAKE_RT_(\w+) (.+?)\s*(?:\/\/.*)?$/);
    if (define && kept.every(Boolean)) yield [define[1], define[2]];
  }
}

// A macro's constant expression: numbers, LUTBAKE_RT_ names, vec2/vec3(...), .x/.y/.z, unary -, + - * / and
// parentheses, component-wise on vectors (arrays) as GLSL does.
function evaluate(expression, names) {
  const tokens = expression.match(/\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+|\w+|[-+*/().,]|\S/g);
  let at = 0;
  const peek = () => tokens[at], take = (t) => { if (tokens[at] !== t) throw new Error(`expected '${t}' at '${tokens[at] ?? 'end'}'`); at += 1; };
  const apply = (f, a, b) => (Array.isArray(a) || Array.isArray(b)
    ? [0, 1, 2].slice(0, (Array.isArray(a) ? a : b).length).map((i) => f(Array.isArray(a) ? a[i] : a, Array.isArray(b) ? b[i] : b)) : f(a, b));
  const ops = { '+': (a, b) => a + b, '-': (a, b) => a - b, '*': (a, b) => a * b, '/': (a, b) => a / b };
  const binary = (next, symbols) => () => {
    let value = next();
    while (symbols.includes(peek())) { const op = tokens[at++]; value = apply(ops[op], value, next()); }
    return value;
  };
  const primary = () => {
    const token = tokens[at++];
    let value;
    if (token === '(') { value = sum(); take(')'); }
    else if (token === 'vec2' || token === 'vec3') {
      take('('); value = [sum()];
      while (peek() === ',') { at += 1; value.push(sum()); }
      take(')');
    } else if (/^[\d.]/.test(token ?? '')) value = Number(token);
    else if (token?.startsWith('LUTBAKE_RT_') && token.slice(11) in names) value = names[token.slice(11)];
    else throw new Error(`unknown '${token ?? 'end'}'`);
    while (peek() === '.') { at += 1; value = value['xyz'.indexOf(tokens[at++])]; }
    if (value === undefined) throw new Error('bad component');
    return value;
  };
  const unary = () => (peek() === '-' ? (at += 1, apply(ops['-'], 0, unary())) : primary());
  const product = binary(unary, ['*', '/']);
  const sum = binary(product, ['+', '-']);
  const value = sum();
  if (at !== tokens.length) throw new Error(`unexpected '${tokens[at]}'`);
  return value;
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


// conj(e^(2 pi i turns) - 1) = (-2 s^2, -2 s c), s = sin(pi t), c = cos(pi t) of t = turns - round(turns) by the include's
// near-minimax polynomials in t^2 (lutbake_rt_cis_m1_conj).
function cisM1Conj(turns) {
  const t = turns.sub(floor(turns.add(0.5)));
  const u = t.mul(t);
  const s2 = t.mul(float(-6.28317941).add(u.mul(float(10.3347356).add(u.mul(float(-5.08720983).add(u.mul(1.11679188)))))));
  const c = float(0.999999953).add(u.mul(float(-4.93479286).add(u.mul(float(4.05841191).add(u.mul(float(-1.33188014)
    .add(u.mul(0.219696764))))))));
  return vec2(float(-0.5).mul(s2).mul(s2), s2.mul(c));
}

// sqrt(2) times the principal square root for Im z >= 0, its parts picked by one select (lutbake_rt_sqrt2).
function csqrt2(z) {
  const h = sqrt(max(length(z).add(abs(z.x)), 1e-30));
  const l = z.y.div(h);
  return select(z.x.greaterThanEqual(0.0), vec2(h, l), vec2(l, h));
}

// Interface 1-2 of one polarization by admittances y1, y2: a = r12, -a/2, 1 + a, 1 - a^2, 1 - a^2 + 1e-30, a^2
// (lutbake_rt_face).
function face(y1, y2) {
  const i2 = float(2).div(y1.add(y2));
  const u1 = y1.mul(i2);
  const a = u1.sub(1);
  const ea = u1.mul(y2.mul(i2));
  return { a, na: float(-0.5).mul(a), u1, ea, eaTiny: ea.add(1e-30), a2: a.mul(a) };
}

// The film's part (lutbake_rt_film): sqrt(2) g2 and sqrt(2) g2 / eta2^2, (eta1 sin theta)^2, interfaces 1-2,
// conj(e^(i theta) - 1) and cos theta, the zoom (ba = 2X / ZOOM and the Moebius map's constants in texture units),
// the slice pair's tile centre (texture coordinates, scanline 0 at v = 0) and its second slice's weight.
function film(c, cosTheta, thicknessNm, eta1, eta2) {
  const c1 = clamp(cosTheta, 0.0, 1.0);
  const e1c = eta1.mul(c1);
  const g2 = sqrt(max(eta2.sub(eta1).mul(eta2.add(eta1)).add(e1c.mul(e1c)), 1e-30));
  const h = g2.div(eta2.mul(eta2));
  const xh = thicknessNm.mul(g2);
  const em1c = cisM1Conj(xh.mul(2 * c.NU0));
  const ba = xh.mul(4 / c.ZOOM);
  const s = min(sqrt(xh.mul(2 * c.LAST_SLICE * c.LAST_SLICE / c.X_MAX)), c.LAST_SLICE - 1 / 4096);
  const j = floor(s);
  const tile = j.add(0.5).mul(1 / c.TILES);
  return {
    e1c, g2r: float(1.41421356).mul(g2), hr: float(1.41421356).mul(h), sin2: eta1.sub(e1c).mul(eta1.add(e1c)),
    faceS: face(e1c, g2), faceP: face(c1, eta1.mul(h)), em1c, cosPhase: float(1).add(em1c.x), ba,
    kv: vec2(...c.SCALE).mul(ba.mul(float(2).add(ba))), w0: float(-c.SCALE[0]).sub(ba.mul(c.SCALE[0])),
    centre: vec2(fract(tile).mul(c.TILE_STEP[0]), floor(tile).mul(c.TILE_STEP[1]).add(c.TILE_ORIGIN)), xt: s.sub(j),
  };
}

// One polarization from conj(zeta) (lutbake_rt_pol; docs/spectral.md): c0, g = conj(K e^(i theta) / zeta) (its real
// part the white's share) and w, the table coordinate's offset in texture units (partial fractions in e = ba + zeta).
function polarization(c, fc, p, q, pq, f) {
  const n4 = float(4).div(dot(pq, pq));
  const nat2 = vec2(dot(q, pq), q.x.mul(pq.y).sub(q.y.mul(pq.x))).mul(fc.na.mul(n4));
  const eb = max(dot(p, q).mul(n4), 0.0);
  const eq = fc.ea.div(fc.eaTiny.add(fc.a2.mul(eb)));
  const kr = eb.mul(eq);
  const c0 = fc.a2.add(fc.ea.mul(eq.sub(kr)));
  const abx = fc.a.add(nat2.x);
  const zc = vec2(fc.u1.add(nat2.x).add(abx.mul(f.em1c.x).sub(nat2.y.mul(f.em1c.y))),
    nat2.y.mul(f.cosPhase).add(abx.mul(f.em1c.y)));
  const kz = kr.div(max(dot(zc, zc), 1e-30));
  const g = vec2(kr.sub(kz.mul(zc.x)), kz.mul(zc.y));
  const ec = vec2(f.ba.add(zc.x), zc.y);
  const t = f.kv.div(max(dot(ec, ec), 1e-30));
  const reach = vec2(...c.REACH);
  const w = clamp(vec2(f.w0.add(t.x.mul(ec.x)), t.y.mul(ec.y)), reach.negate(), reach);
  return { c0, g, w };
}

// Both polarizations over base eta3 + i kappa3 (lutbake_rt_base): g3 scaled by sqrt(2), p by the film's
// sqrt(2) g2 / eta2^2, n3^2 = zx + (eta1 sin theta)^2.
function base(c, f, eta1, eta3, kappa3) {
  const ek = float(2).mul(eta3).mul(kappa3);
  const zx = eta3.sub(eta1).mul(eta3.add(eta1)).sub(kappa3.mul(kappa3)).add(f.e1c.mul(f.e1c));
  const g3 = csqrt2(vec2(zx, ek));
  const s = polarization(c, f.faceS, vec2(f.g2r, 0.0), g3, vec2(f.g2r.add(g3.x), g3.y), f);
  const pn = vec2(zx.add(f.sin2), ek).mul(f.hr);
  return { s, p: polarization(c, f.faceP, pn, g3, pn.add(g3), f) };
}

// One bilinear read at mip level 0 (valid in any control flow).
const texel = (runtime, uv) => texture(runtime.table, uv).level(0);

// One polarization's read weights, the slices' blend folded into g (lutbake_rt_weights).
const weights = (g, xt) => { const g1 = g.mul(xt); return vec4(g.sub(g1), g1); };

// White's share: (c0_s + c0_p)/2 + Re of both K e^(i theta) / zeta (lutbake_rt_white).
const white = (b) => float(0.5).mul(b.s.c0.add(b.p.c0)).add(b.s.g.x).add(b.p.g.x);

// One polarization's single read, the slices blended in the texel (lutbake_rt_read1).
const read1 = (runtime, uv, g, xt) => { const v = texel(runtime, uv); return dot(mix(v.xy, v.zw, xt), g); };

// Channel band's reflectance over one base: centre, the pair's tile centre in the band (lutbake_rt_channel).
function channel(runtime, f, b, centre, band) {
  return white(b).mul(runtime.constants.WHITE[band]).add(read1(runtime, centre.add(b.s.w), b.s.g, f.xt))
    .add(read1(runtime, centre.add(b.p.w), b.p.g, f.xt));
}

// Linear RGB reflectance of ambient eta1 | film eta2, thicknessNm | base eta3 + i kappa3, one base index
// (lutbake_iridescence); numbers or float nodes.
export function lutbakeIridescenceNode(runtime, cosTheta, thicknessNm, eta1, eta2, eta3, kappa3) {
  const c = runtime.constants;
  const f = film(c, float(cosTheta), float(thicknessNm), float(eta1), float(eta2));
  const b = base(c, f, float(eta1), float(eta3), float(kappa3));
  const us = f.centre.add(b.s.w), up = f.centre.add(b.p.w);
  const ws = weights(b.s.g, f.xt), wp = weights(b.p.g, f.xt);
  const read = (uv, k, w) => dot(texel(runtime, k ? vec2(uv.x, uv.y.add(k * c.BAND_STEP)) : uv), w);
  return white(b).mul(vec3(...c.WHITE)).add(vec3(read(us, 0, ws).add(read(up, 0, wp)),
    read(us, 1, ws).add(read(up, 1, wp)), read(us, 2, ws).add(read(up, 2, wp))));
}

// The same with one base index per channel, eta3 and kappa3 vec3 nodes (lutbake_iridescence_rgb: metals).
export function lutbakeIridescenceRgbNode(runtime, cosTheta, thicknessNm, eta1, eta2, eta3, kappa3) {
  const c = runtime.constants;
  const f = film(c, float(cosTheta), float(thicknessNm), float(eta1), float(eta2));
  const channels = [[eta3.x, kappa3.x], [eta3.y, kappa3.y], [eta3.z, kappa3.z]];
  return vec3(...channels.map(([e, k], band) => channel(runtime, f, base(c, f, float(eta1), e, k),
    band ? vec2(f.centre.x, f.centre.y.add(band * c.BAND_STEP)) : f.centre, band)));
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
