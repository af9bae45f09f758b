// lutbake iridescence for PlayCanvas (playcanvas 2, pinned in engine/package.json): a shader chunk override
// that replaces StandardMaterial's thin-film Fresnel term (the chunk iridescenceDiffractionPS, whose
// getIridescence implements KHR_materials_iridescence's approximation) by lutbake's runtime table: any film
// index and thickness, 6 bilinear reads.
// The material's iridescence parameters keep their meaning: iridescence, iridescenceRefractionIndex (the
// film's index), iridescenceThicknessMin/Max and iridescenceThicknessMap (nm). The base under the film: the
// material's index (PlayCanvas stores refractionIndex = 1 / ior) where it is dielectric; where it is metallic
// (useMetalness, metalness > 0) the per-channel n, k you pass as `metal` (lutbake's named metals at
// 611/549/464 nm: exact.base_rgb, docs/engines.md); the terms are mixed by metalness, each evaluated only
// where its weight is non-zero. WebGL2 (GLSL) only: the WGSL chunks of PlayCanvas's WebGPU device are not
// replaced (docs/engines.md).
//
//   import { loadLutbakeRuntime, lutbakeIridescence } from './lutbake-playcanvas.js';
//   const runtime = await loadLutbakeRuntime('luts/runtime/lutbake-runtime', app.graphicsDevice);
//   lutbakeIridescence(material, { runtime });                    // a StandardMaterial with useIridescence
//   lutbakeIridescence(material, { runtime, metal: { eta: [0.27, 0.68, 1.32], kappa: [3.61, 2.63, 2.29] } });
//
// `output` (tests, debugging): 'fresnel' writes the film's linear RGB Fresnel term instead of the lit colour,
// 'parameters' the (cos theta, thickness nm, film index) it used, 'basecolor' the base colour (a texture-driven
// metal's F0) and 'metallic' the metalness lutbake's term read (alpha 1 in all: a blended material, such as a
// transmitting one, would scale a smaller alpha in); with mode 'playcanvas' they are PlayCanvas's (no base colour).
//
// iridescenceThicknessMap: PlayCanvas 2.23.3's own shader does not compile with it (the sampler is undeclared);
// both modes apply fixIridescenceThicknessMap, which stock PlayCanvas materials can use alone:
//   fixIridescenceThicknessMap(material, app.graphicsDevice);
import * as pc from 'playcanvas';
import { loadRuntimeTable } from './lutbake-exr.js';
import { SERVES, bakeTerms, loadBakeManifest, partRoutes } from './lutbake-routes.js';

// The runtime table as an RGBA half float texture: bilinear, clamped, no mipmaps, not anisotropic; scanline 0
// at v = 0 (lutbake-exr.js), so the include is compiled with LUTBAKE_SCANLINE0_AT_V0 1.
export async function loadLutbakeRuntime(stem, device) {
  const runtime = await loadRuntimeTable(stem);
  return { table: lutbakeTexture(device, runtime, 'lutbake-runtime'), include: runtime.include, device };
}

function lutbakeTexture(device, { width, height, texels }, name) {
  return new pc.Texture(device, {
    name, width, height, format: pc.PIXELFORMAT_RGBA16F, mipmaps: false, anisotropy: 1,
    minFilter: pc.FILTER_LINEAR, magFilter: pc.FILTER_LINEAR,
    addressU: pc.ADDRESS_CLAMP_TO_EDGE, addressV: pc.ADDRESS_CLAMP_TO_EDGE, levels: [texels],
  });
}

// A `lutbake bake --gltf` output (lutbake-routes.js) with its atlas, if a slice serves a part, and its 4D LUTs
// as textures like the runtime table's: for lutbakeGltfOptions({ bake }). Both loaders keep the device: the
// thickness map's fix reads its chunks.
export async function loadLutbakeBakePlaycanvas(manifestUrl, device) {
  const bake = await loadBakeManifest(manifestUrl, (table, name) => lutbakeTexture(device, table, `lutbake-${name}`));
  return { ...bake, device };
}

// PlayCanvas 2.23.3's StandardMaterial allocates iridescenceThicknessMap's sampler by setting
// STD_IRIDESCENCETHICKNESS_TEXTURE_ALLOCATE (STD_, the property's name in capitals, _TEXTURE_ALLOCATE), but its
// declarations chunk (stdDeclarationPS) declares the sampler only under STD_IRIDESCENCE_THICKNESS_TEXTURE_ALLOCATE,
// which nothing sets: the thickness chunk (iridescenceThicknessPS) reads an undeclared sampler and the shader does
// not compile. The fix: the device's own thickness chunk, preceded by the declaration under the define the
// material sets (and not where the other is set, should a later version set that one).
const THICKNESS_ALLOCATED = 'STD_IRIDESCENCETHICKNESS_TEXTURE_ALLOCATE';
const THICKNESS_DECLARED = 'STD_IRIDESCENCE_THICKNESS_TEXTURE_ALLOCATE';

// The fixed thickness chunk, or null where the device's declarations already declare the sampler under the
// define the material sets (a PlayCanvas that fixed it: declaring it twice would not compile).
function thicknessMapChunk(device) {
  const stock = pc.ShaderChunks.get(device, pc.SHADERLANGUAGE_GLSL);
  if (stock.get('stdDeclarationPS').includes(THICKNESS_ALLOCATED)) return null;
  return `#if defined(${THICKNESS_ALLOCATED}) && !defined(${THICKNESS_DECLARED})
uniform sampler2D {STD_IRIDESCENCETHICKNESS_TEXTURE_NAME};
#endif
${stock.get('iridescenceThicknessPS')}`;
}

// Make a StandardMaterial's iridescenceThicknessMap compile on `device` (WebGL2, GLSL chunks) where PlayCanvas
// needs it (thicknessMapChunk); returns the material, updated. Its thickness then follows the map as
// KHR_materials_iridescence says: mix(iridescenceThicknessMin, iridescenceThicknessMax, the map's G).
export function fixIridescenceThicknessMap(material, device) {
  const chunk = thicknessMapChunk(device);
  if (chunk) material.getShaderChunks(pc.SHADERLANGUAGE_GLSL).set('iridescenceThicknessPS', chunk);
  material.update();
  return material;
}

// The chunk's interface: getIridescence(cos theta, base F0, thickness nm), and the film index uniform the
// stock chunk declares. `film` is the term's GLSL expression.
function chunk(declarations, film) {
  return `
uniform float material_iridescenceRefractionIndex;
vec3 lutbakeFresnel;
vec3 lutbakeParameters;
vec3 lutbakeBaseColour;
float lutbakeMetallic;
${declarations}
vec3 getIridescence(float cosTheta, vec3 specularity, float iridescenceThickness) {
  float eta2 = material_iridescenceRefractionIndex;
  lutbakeFresnel = ${film};
  lutbakeParameters = vec3(cosTheta, iridescenceThickness, eta2);
  return lutbakeFresnel;
}
`;
}

// The runtime table's terms over the material's base (eta3: its index; a metal per channel).
const RUNTIME_TERMS = {
  dielectric: 'lutbake_iridescence(lutbakeTable, cosTheta, thicknessNm, 1.0, eta2, eta3, 0.0)',
  metal: 'lutbake_iridescence_rgb(lutbakeTable, cosTheta, thicknessNm, 1.0, eta2, lutbakeMetalEta, lutbakeMetalKappa)',
};

// lutbake's term: `terms` (GLSL in cosTheta, thicknessNm, eta2, eta3 and lutbakeBaseColour, the pixel's base
// colour before PlayCanvas scales it by 1 - metalness; absent: 0) mixed by metalness, with the samplers and
// includes they read (the runtime table's, a bake's atlas's and 4D LUT's: bakeTerms, lutbake-routes.js).
function lutbakeChunk({ runtime, bake }) {
  const terms = bake ? bake.terms : RUNTIME_TERMS;
  return chunk(`
${runtime ? 'uniform highp sampler2D lutbakeTable;' : ''}
${bake && bake.atlas ? 'uniform highp sampler2D lutbakeAtlas;' : ''}
${bake && bake.lut ? 'uniform highp sampler2D lutbakeLut;' : ''}
uniform vec3 lutbakeMetalEta;
uniform vec3 lutbakeMetalKappa;
#define LUTBAKE_SCANLINE0_AT_V0 1
${runtime ? runtime.include : ''}
${bake ? bake.include : ''}
vec3 lutbakeFilm(float cosTheta, float thicknessNm, float eta2) {
#ifdef LIT_METALNESS
  float metallic = litArgs_metalness;
  float eta3 = 1.0 / litArgs_ior;
#else
  float metallic = 0.0;
  float eta3 = 1.5;
#endif
  lutbakeBaseColour = dAlbedo;
  lutbakeMetallic = metallic;
  vec3 dielectric = vec3(0.0);
  vec3 metal = vec3(0.0);
  if (metallic < 1.0) dielectric = ${terms.dielectric || 'vec3(0.0)'};
  if (metallic > 0.0) metal = ${terms.metal || 'vec3(0.0)'};
  return mix(dielectric, metal, metallic);
}`, 'lutbakeFilm(cosTheta, iridescenceThickness, eta2)');
}

const MODES = ['runtime', 'playcanvas'];
const OUTPUTS = { fresnel: 'vec4(lutbakeFresnel, 1.0)', parameters: 'vec4(lutbakeParameters, 1.0)',
                  basecolor: 'vec4(lutbakeBaseColour, 1.0)', metallic: 'vec4(vec3(lutbakeMetallic), 1.0)' };
const DIELECTRIC_METAL = { eta: [1.5, 1.5, 1.5], kappa: [0, 0, 0] };

// Replace a StandardMaterial's iridescence term (mode 'runtime'), or keep PlayCanvas's (its chunk from
// `device`) and only capture it for `output` (mode 'playcanvas'); returns the material.
//
// `bake` (lutbakeGltfOptions: a glTF bake's routes, bakeTerms of lutbake-routes.js) replaces the runtime
// table's terms by its own. `device`: the graphics device (default: the runtime table's), whose chunks the
// thickness map's fix and mode 'playcanvas' read.
export function lutbakeIridescence(material, { runtime = null, bake = null, mode = runtime || bake ? 'runtime' : 'playcanvas',
                                               metal = DIELECTRIC_METAL, output = null, device = runtime?.device } = {}) {
  if (!MODES.includes(mode)) throw new Error(`lutbakeIridescence: mode '${mode}' is not one of ${MODES.join(', ')}`);
  if (mode === 'runtime' && !runtime && !bake) throw new Error("lutbakeIridescence: mode 'runtime' needs the runtime table");
  if (!device) throw new Error('lutbakeIridescence: needs the graphics device (its chunks): pass device, or a runtime table from loadLutbakeRuntime');
  if (output !== null && !(output in OUTPUTS)) throw new Error(`lutbakeIridescence: output '${output}' is not one of ${Object.keys(OUTPUTS).join(', ')}`);
  const chunks = material.getShaderChunks(pc.SHADERLANGUAGE_GLSL);
  if (mode === 'runtime') {
    chunks.set('iridescenceDiffractionPS', lutbakeChunk({ runtime, bake }));
    if (runtime) material.setParameter('lutbakeTable', runtime.table);
    if (bake && bake.atlas) material.setParameter('lutbakeAtlas', bake.atlas);
    if (bake && bake.lut) material.setParameter('lutbakeLut', bake.lut);
    material.setParameter('lutbakeMetalEta', metal.eta);
    material.setParameter('lutbakeMetalKappa', metal.kappa);
  } else {
    const stock = pc.ShaderChunks.get(device, pc.SHADERLANGUAGE_GLSL)
      .get('iridescenceDiffractionPS').replace(/vec3 getIridescence\(/, 'vec3 playcanvasIridescence(');
    chunks.set('iridescenceDiffractionPS', chunk(stock,
      'playcanvasIridescence(cosTheta, specularity, iridescenceThickness)').replace(
      'uniform float material_iridescenceRefractionIndex;\n', ''));
  }
  if (output) chunks.set('outputPS', `gl_FragColor = ${OUTPUTS[output]};`);
  return fixIridescenceThicknessMap(material, device);
}

// The glTF-loading hook: container asset options whose material postprocess serves every
// KHR_materials_iridescence material of an asset from the runtime table (PlayCanvas's glTF parser has
// already set its film and base index). glTF carries no n, k for a metallic base: `metals` maps a glTF
// material's name to them (lutbake's named metals: exact.base_rgb).
//
//   const asset = new pc.Asset('lamp', 'container', { url: 'IridescenceLamp.gltf' }, null,
//                              lutbakeGltfOptions({ runtime, metals: { 'Lamp metal': { eta, kappa } } }));
//   app.assets.add(asset); app.assets.load(asset);
//
// With `bake` (loadLutbakeBakePlaycanvas) each glTF material the bake's manifest records is served by its
// routes (lutbake-routes.js: slice, slice per channel, runtime table, constant, a texture-driven metal's 4D
// LUT or runtime table at the pixel's base colour; `serve: 'runtime'` sends every part to the table),
// recorded in material.lutbake ({gltfIndex, name, parts}); the glTF material's index is its place in the
// asset's materials, which the global preprocess hook keeps. `serve: 'playcanvas'` (tests, comparisons)
// keeps PlayCanvas's own term on every iridescent material, with the thickness map's fix and `output`.
const GLTF_SERVES = [...SERVES, 'playcanvas'];

export function lutbakeGltfOptions({ runtime = null, metals = {}, output = null, bake = null, serve = 'bake' }) {
  if (!GLTF_SERVES.includes(serve)) throw new Error(`lutbakeGltfOptions: serve '${serve}' is not ${GLTF_SERVES.join(', ')}`);
  const device = runtime?.device ?? bake?.device;
  let gltfMaterials = [];
  const served = (gltfMaterial, material) => {
    const record = bake.records.get(gltfMaterials.indexOf(gltfMaterial));
    if (!record) {  // not in the bake: PlayCanvas's own film, which needs the fix to compile a thickness map
      if (gltfMaterial.extensions?.KHR_materials_iridescence) fixIridescenceThicknessMap(material, device);
      return;
    }
    const routes = partRoutes(bake, record, { runtime: Boolean(runtime), serve });
    lutbakeIridescence(material, { runtime, bake: bakeTerms(bake, record, routes), output, device });
    material.lutbake = { gltfIndex: record.gltf_index, name: record.name, parts: routes };
  };
  return {
    global: { preprocess(gltf) { gltfMaterials = gltf.materials || []; } },
    material: {
      postprocess(gltfMaterial, material) {
        if (serve !== 'playcanvas' && bake) return served(gltfMaterial, material);
        if (!gltfMaterial.extensions?.KHR_materials_iridescence) return;
        if (serve === 'playcanvas') return lutbakeIridescence(material, { mode: 'playcanvas', output, device });
        lutbakeIridescence(material, { runtime, metal: metals[gltfMaterial.name] || undefined, output });
      },
    },
  };
}
