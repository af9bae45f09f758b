// lutbake iridescence for three.js: a drop-in replacement of MeshPhysicalMaterial's thin-film Fresnel term
// (three's evalIridescence, KHR_materials_iridescence) by lutbake's runtime table (the default: any film
// index, 6 bilinear reads), its exact series, or a baked lutbake LUT.
// The glTF parameters keep their meaning: iridescence, iridescenceIOR (the film's index) and
// iridescenceThicknessMinimum/Maximum and iridescenceThicknessMap (the film's thickness in nm). The base under the film:
// the material's `ior` for dielectrics; for metals (metalness 1) the per-channel n, k you pass as
// `metal` (lutbake's named metals at 611/549/464 nm: exact.base_rgb, docs/engines.md). Each branch runs only
// where it is needed: the dielectric one where metalness < 1, the metallic one where metalness > 0.
//
//   import { loadLutbakeRuntime, lutbakeIridescence } from './lutbake-iridescence.js';
//   const runtime = await loadLutbakeRuntime('luts/lutbake-runtime', { renderer });   // float32 where the context filters it
//   lutbakeIridescence(material, { runtime });                              // dielectric base: material.ior
//   lutbakeIridescence(material, { runtime, metal: { eta: [0.27, 0.68, 1.32], kappa: [3.61, 2.63, 2.29] } });
//   lutbakeIridescence(material, { exact: await loadLutbakeExact('engine/exact/lutbake-exact') });
//   lutbakeIridescence(material, { lut: await loadLutbakeLut('luts/lutbake-eta2-1.33'), lutRule: 'linear' });
//
// `output` (tests, debugging): 'fresnel' writes the film's linear RGB Fresnel term instead of the lit colour;
// 'parameters' writes (cos theta, thickness nm, iridescenceIOR) the pixel used. Set it also with mode 'three'
// to read three.js's own term.
import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';

async function loadText(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.text();
}

// The members of a lutbake set identify it (docs/lut-format.md, Guarantees): the EXR header's
// `lutbake.content_hash` (a LUT, an exact table) or `lutbake.scene_hash` (a scene atlas) is the hash the
// include's second line names. A folder copied, or a bake killed, while a set's files were being renamed
// can hold an EXR of one set beside an include of another; sampling it would read the wrong axes. Throws
// (naming `url`) unless the two belong to one set.
export function checkSameSet(header, include, url) {
  // Only the lines lutbake writes at fixed places, the hash before any name (names are escaped: one line each).
  const [first = '', second = ''] = include.split('\n', 2);
  const lut = second.match(/^\/\/ content hash ([0-9a-f]+);/);
  const scene = first.match(/^\/\/ lutbake scene material table \(scene hash ([0-9a-f]+)\) for /);
  const inExr = lut ? header['lutbake.content_hash'] : header['lutbake.scene_hash'];
  const inInclude = lut ? lut[1] : scene && scene[1];
  if (!inInclude || typeof inExr !== 'string') {
    throw new Error(`${url}: not a lutbake set (no content or scene hash in the EXR header and include)`);
  }
  if (lut ? inExr !== inInclude : !inExr.startsWith(inInclude)) {
    throw new Error(`${url}: the EXR (hash ${inExr.slice(0, 16)}) and its include (hash ${inInclude.slice(0, 16)}) `
      + 'are of different bakes (copied or interrupted mid-commit): bake the set again');
  }
}

// An EXR as a texture, with its header, and the include beside it, checked to be one set.
async function loadChecked(stem, loader) {
  const [{ texture, header }, include] = await Promise.all([
    new Promise((resolve, reject) => loader.load(`${stem}.exr`, (t, data) => resolve({ texture: t, header: data.header }),
      undefined, reject)),
    loadText(`${stem}.glsl`),
  ]);
  checkSameSet(header, include, stem);
  return { table: texture, include };
}

// The runtime table (linear filtering) and its include. Its texels are uploaded as float32 where the context
// filters float32 textures (OES_texture_float_linear: desktop GPUs, SwiftShader; three.js enables it), where
// the six filtered reads cost less than half ones (docs/engines.md), and as half floats elsewhere (many mobile
// GPUs; EXRLoader's default): the same colours, the half texels are exact in float32. `renderer` (a
// THREE.WebGLRenderer) decides at run time; `precision` 'float' or 'half' forces a choice (float needs the
// extension). The choice and why are returned as `precision` and `precisionReason`.
export async function loadLutbakeRuntime(stem, { renderer = null, precision = null } = {}) {
  const filtersFloat = renderer !== null && renderer.extensions.has('OES_texture_float_linear');
  if (![null, 'float', 'half'].includes(precision)) throw new Error(`loadLutbakeRuntime: precision '${precision}' is not 'float' or 'half'`);
  if (precision === 'float' && !filtersFloat) {
    throw new Error('loadLutbakeRuntime: a float table needs a renderer whose context filters float32 (OES_texture_float_linear)');
  }
  const chosen = precision ?? (filtersFloat ? 'float' : 'half');
  const runtime = await loadChecked(stem, new EXRLoader().setDataType(chosen === 'float' ? THREE.FloatType : THREE.HalfFloatType));
  const precisionReason = precision ? 'asked for'
    : renderer === null ? 'no renderer given' : `OES_texture_float_linear ${filtersFloat ? 'present' : 'absent'}`;
  return { ...runtime, precision: chosen, precisionReason };
}

// The exact mode's table as float32 texels read with texelFetch (no filtering, so no float-linear extension).
export async function loadLutbakeExact(stem) {
  const exact = await loadChecked(stem, new EXRLoader().setDataType(THREE.FloatType));
  exact.table.minFilter = exact.table.magFilter = THREE.NearestFilter;
  return { ...exact, precision: 'float', precisionReason: 'texelFetch: no filtering needed' };
}

// A baked LUT (EXRLoader's defaults: half float, linear filtering) and its include; `ident` is its constant.
export async function loadLutbakeLut(stem) {
  const lut = await loadChecked(stem, new EXRLoader());
  return { ...lut, ident: lut.include.match(/const LutbakeLut (\w+) =/)[1], precision: 'half', precisionReason: "EXRLoader's default" };
}

// GLSL for the film's Fresnel term at (dotNVi, material), one expression per base: three's iridescenceIOR and
// thickness, the base from material.ior (dielectric) or the lutbakeMetal* uniforms (metallic, per channel).
function fresnelTerms(mode, source, lutRule) {
  const film = 'dotNVi, material.iridescenceThickness, 1.0, material.iridescenceIOR';
  if (mode === 'runtime') {
    return [`lutbake_iridescence(lutbakeTable, ${film}, material.ior, 0.0)`,
            `lutbake_iridescence_rgb(lutbakeTable, ${film}, lutbakeMetalEta, lutbakeMetalKappa)`];
  }
  if (mode === 'exact') {
    return [`lutbake_exact(lutbakeTable, ${film}, material.ior, 0.0)`,
            `lutbake_exact_rgb(lutbakeTable, ${film}, lutbakeMetalEta, lutbakeMetalKappa)`];
  }
  // A LUT holds one film index: iridescenceIOR must equal its eta2 (checked on the host).
  const sample = lutRule === 'linear' ? 'lutbake_sample_linear' : 'lutbake_sample';
  const at = (eta, kappa) => `${sample}(lutbakeTable, ${source.ident}, dotNVi, 2.0 * ${source.ident}.eta2 * material.iridescenceThickness, ${eta}, ${kappa})`;
  return [
    at('material.ior', '0.0'),
    `vec3(${at('lutbakeMetalEta.r', 'lutbakeMetalKappa.r')}.r, ${at('lutbakeMetalEta.g', 'lutbakeMetalKappa.g')}.g, ${at('lutbakeMetalEta.b', 'lutbakeMetalKappa.b')}.b)`,
  ];
}

// three's two evalIridescence calls, each replaced by its lutbake term where its weight is non-zero.
const DIELECTRIC_CALL = /vec3 iridescenceFresnelDielectric = evalIridescence\( 1\.0, material\.iridescenceIOR, dotNVi, material\.iridescenceThickness, material\.specularColor \);/;
const METALLIC_CALL = /vec3 iridescenceFresnelMetallic = evalIridescence\( 1\.0, material\.iridescenceIOR, dotNVi, material\.iridescenceThickness, material\.diffuseColor \);/;

const OUTPUTS = { fresnel: 'vec4(material.iridescenceFresnel, 1.0)',
                  parameters: 'vec4(dotNVi, material.iridescenceThickness, material.iridescenceIOR, 1.0)' };

const MODES = ['runtime', 'exact', 'lut', 'three'];

export function lutbakeIridescence(material, { runtime = null, exact = null, lut = null,
                                               mode = runtime ? 'runtime' : exact ? 'exact' : lut ? 'lut' : 'three',
                                               lutRule = null, metal = { eta: [1.5, 1.5, 1.5], kappa: [0, 0, 0] },
                                               output = null } = {}) {
  if (!MODES.includes(mode)) throw new Error(`lutbakeIridescence: mode '${mode}' is not one of ${MODES.join(', ')}`);
  if (lutRule !== null && !['cubic', 'linear'].includes(lutRule)) {
    throw new Error(`lutbakeIridescence: lutRule '${lutRule}' is not 'cubic' or 'linear'`);
  }
  const source = { runtime, exact, lut, three: null }[mode];
  if (mode !== 'three' && !source) throw new Error(`lutbakeIridescence: mode '${mode}' needs its table`);
  if (mode === 'lut') {
    const eta2 = Number(source.include.match(/film eta2 = ([0-9.]+)/)[1]);
    if (Math.abs(material.iridescenceIOR - eta2) > 1e-6) {
      throw new Error(`lutbakeIridescence: the LUT is baked for iridescenceIOR ${eta2}, the material has ${material.iridescenceIOR}`);
    }
  }
  material.onBeforeCompile = (shader) => {
    let fragment = shader.fragmentShader;
    if (mode !== 'three') {
      const [dielectric, metallic] = fresnelTerms(mode, source, lutRule);
      shader.uniforms.lutbakeTable = { value: source.table };
      shader.uniforms.lutbakeMetalEta = { value: new THREE.Vector3(...metal.eta) };
      shader.uniforms.lutbakeMetalKappa = { value: new THREE.Vector3(...metal.kappa) };
      const begin = THREE.ShaderChunk.lights_fragment_begin
        .replace(DIELECTRIC_CALL, `vec3 iridescenceFresnelDielectric = vec3(0.0);
		if (material.metalness < 1.0) iridescenceFresnelDielectric = ${dielectric};`)
        .replace(METALLIC_CALL, `vec3 iridescenceFresnelMetallic = vec3(0.0);
		if (material.metalness > 0.0) iridescenceFresnelMetallic = ${metallic};`);
      if (begin.includes('evalIridescence')) throw new Error('lutbakeIridescence: three.js changed lights_fragment_begin');
      fragment = fragment
        .replace('#include <iridescence_fragment>', `#include <iridescence_fragment>
uniform highp sampler2D lutbakeTable;
uniform highp vec3 lutbakeMetalEta;
uniform highp vec3 lutbakeMetalKappa;
${source.include}`)
        .replace('#include <lights_fragment_begin>', begin);
    }
    if (output) fragment = fragment.replace('#include <dithering_fragment>', `#include <dithering_fragment>
  gl_FragColor = ${OUTPUTS[output]};`);
    shader.fragmentShader = fragment;
  };
  // Programs are cached by this key: materials patched differently must not share one.
  material.customProgramCacheKey = () => `lutbake:${mode}:${lutRule}:${output}:${source ? source.include.length : 0}`;
  // What serves the film's term, and its table's texel type (and why): the drop-in's report.
  material.userData.lutbake = { mode, precision: source ? source.precision : null, precisionReason: source ? source.precisionReason : null };
  material.needsUpdate = true;
  return material;
}
