// lutbake iridescence for Babylon.js (@babylonjs/core 9, pinned in engine/package.json): a material plugin that
// replaces PBRMaterial's thin-film Fresnel term (Babylon's evalIridescence, KHR_materials_iridescence) by
// lutbake's runtime table: any film index and thickness, 6 bilinear reads.
// The material's iridescence parameters keep their meaning: material.iridescence.intensity, .indexOfRefraction
// (the film's index), .minimumThickness/.maximumThickness and .thicknessTexture (nm). The base under the film:
// the material's indexOfRefraction where it is dielectric; where it is metallic (metallic > 0, metallic
// workflow) the per-channel n, k you pass as `metal` (lutbake's named metals at 611/549/464 nm: exact.base_rgb,
// docs/engines.md); the two terms are mixed by the material's metallic value, each evaluated only where its
// weight is non-zero. Under a clear coat the ambient index is the coat's, as in Babylon.
//
//   import { loadLutbakeRuntime, lutbakeIridescence } from './lutbake-babylon.js';
//   const runtime = await loadLutbakeRuntime('luts/runtime/lutbake-runtime', scene);  // `lutbake runtime-table`
//   lutbakeIridescence(material, { runtime });                                         // a PBRMaterial
//   lutbakeIridescence(material, { runtime, metal: { eta: [0.27, 0.68, 1.32], kappa: [3.61, 2.63, 2.29] } });
//
// `output` (tests, debugging): 'fresnel' writes the film's linear RGB Fresnel term instead of the lit colour,
// 'parameters' the (cos theta, thickness nm, film index) it used, 'basecolor' the base colour (a texture-driven
// metal's F0), 'metallic' the metallic weight (alpha 1 in all: a blended material would scale a smaller alpha
// in); with mode 'babylon' they are Babylon's own.
import { MaterialPluginBase } from '@babylonjs/core/Materials/materialPluginBase.js';
import { RawTexture } from '@babylonjs/core/Materials/Textures/rawTexture.js';
import { Texture } from '@babylonjs/core/Materials/Textures/texture.js';
import { Constants } from '@babylonjs/core/Engines/constants.js';
import { pbrBlockIridescence } from '@babylonjs/core/Shaders/ShadersInclude/pbrBlockIridescence.js';
import { loadRuntimeTable } from './lutbake-exr.js';

// The runtime table as an RGBA half float texture with bilinear filtering, clamped, no mipmaps, not anisotropic; scanline 0 at
// v = 0 (lutbake-exr.js), so the include is compiled with LUTBAKE_SCANLINE0_AT_V0 1.
export async function loadLutbakeRuntime(stem, scene) {
  const { width, height, texels, include, header } = await loadRuntimeTable(stem);
  return { table: lutbakeTexture({ width, height, texels }, scene), include, hash: header['lutbake.content_hash'] };
}

// RGBA half texels (lutbake-exr.js) as the texture lutbake's includes read: bilinear, clamped, no mipmaps.
export function lutbakeTexture({ width, height, texels }, scene) {
  const texture = new RawTexture(texels, width, height, Constants.TEXTUREFORMAT_RGBA, scene, false, false,
    Texture.BILINEAR_SAMPLINGMODE, Constants.TEXTURETYPE_HALF_FLOAT);
  texture.wrapU = texture.wrapV = Texture.CLAMP_ADDRESSMODE;
  // Babylon's textures filter anisotropically (level 4) by default: between neighbouring pixels the table
  // coordinates jump (they are film parameters, not surface positions), and anisotropic filtering would
  // average texels along that jump. One bilinear read is the include's contract.
  texture.anisotropicFilteringLevel = 1;
  return texture;
}

// Babylon's one call of evalIridescence in the PBR fragment shader (pbrBlockIridescence), and main's call of
// the block, where the metallic weight is in scope.
const CALL = 'evalIridescence(topIor,iridescenceIOR,viewAngle,iridescenceThickness,specularEnvironmentR0)';
const BLOCK = 'iridescenceOut=iridescenceBlock(';
const escape = (text) => text.replace(/[.*+?^${}()|[\]\\]/g, '\\$&');

const MODES = { runtime: 1, babylon: 2 };
const OUTPUTS = { fresnel: 1, parameters: 2, basecolor: 3, metallic: 4 };

// The runtime table's term over the material's base: a dielectric of index lutbakeIor, a metal per channel.
const RUNTIME_TERMS = {
  dielectric: 'lutbake_iridescence(lutbakeTable, cosTheta, thicknessNm, eta1, eta2, lutbakeIor, 0.0)',
  metal: 'lutbake_iridescence_rgb(lutbakeTable, cosTheta, thicknessNm, eta1, eta2, lutbakeMetalEta, lutbakeMetalKappa)',
};

// Declarations (before the PBR blocks): the capture of the term for `output`, the pixel's base colour and
// metallic weight (set before the iridescence block), and for lutbake's term the tables (the runtime table, a
// glTF bake's atlas and 4D LUT), their includes and the film's term at (eta1, eta2, cos, d):
// `terms.dielectric` and `terms.metal` (GLSL expressions; absent: 0), mixed by the metallic weight.
// Babylon's preprocessor reads `#if NAME` as `#ifdef NAME`; the includes' `#if` are on
// LUTBAKE_SCANLINE0_AT_V0, defined 1 here, which both readings take as true (and `#if !NAME` as false).
function definitions(include, terms) {
  const capture = `
float lutbakeMetallic = 0.0;
vec3 lutbakeBaseColour = vec3(0.0);
vec3 lutbakeFresnel = vec3(0.0);
vec3 lutbakeParameters = vec3(0.0);
vec3 lutbakeCapture(vec3 fresnel, float cosTheta, float thicknessNm, float eta2) {
  lutbakeFresnel = fresnel;
  lutbakeParameters = vec3(cosTheta, thicknessNm, eta2);
  return fresnel;
}
`;
  if (!terms) return capture;
  return `${capture}
uniform highp sampler2D lutbakeTable;
uniform highp sampler2D lutbakeAtlas;
uniform highp sampler2D lutbakeLut;
#define LUTBAKE_SCANLINE0_AT_V0 1
${include}
vec3 lutbakeFilmFresnel(float eta1, float eta2, float cosTheta, float thicknessNm) {
  vec3 dielectric = vec3(0.0);
  vec3 metallic = vec3(0.0);
  if (lutbakeMetallic < 1.0) dielectric = ${terms.dielectric || 'vec3(0.0)'};
  if (lutbakeMetallic > 0.0) metallic = ${terms.metal || 'vec3(0.0)'};
  return lutbakeCapture(mix(dielectric, metallic, lutbakeMetallic), cosTheta, thicknessNm, eta2);
}
`;
}

class LutbakeIridescencePlugin extends MaterialPluginBase {
  constructor(material, { runtime, mode, metal, output, bake }) {
    super(material, 'LutbakeIridescence', 110, { LUTBAKE_IRIDESCENCE: false, LUTBAKE_MODE: 0, LUTBAKE_OUTPUT: 0, LUTBAKE_TABLE: '' });
    this.runtime = runtime;
    this.mode = mode;
    this.metal = metal;
    this.output = output;
    this.bake = bake;
    this.textures = { lutbakeTable: runtime && runtime.table, lutbakeAtlas: bake && bake.atlas, lutbakeLut: bake && bake.lut };
    this._enable(true);
  }

  getClassName() { return 'LutbakeIridescencePlugin'; }

  prepareDefines(defines) {
    defines.LUTBAKE_IRIDESCENCE = this._material.iridescence.isEnabled;
    defines.LUTBAKE_MODE = MODES[this.mode];
    defines.LUTBAKE_OUTPUT = OUTPUTS[this.output] || 0;
    const table = this.runtime ? `T${this.runtime.hash}` : '';
    defines.LUTBAKE_TABLE = this.mode === 'runtime' ? `${table}${this.bake ? this.bake.key : ''}` : 'none';  // effects are cached by defines
  }

  // The textures lutbake's term reads (the runtime table, a bake's atlas and 4D LUT), by sampler name.
  lutbakeTextures() {
    return this.mode === 'runtime' ? Object.entries(this.textures).filter(([, texture]) => texture) : [];
  }

  isReadyForSubMesh() { return this.lutbakeTextures().every(([, texture]) => texture.isReady()); }

  getSamplers(samplers) { samplers.push(...this.lutbakeTextures().map(([name]) => name)); }

  getUniforms() {
    return {
      ubo: [{ name: 'lutbakeIor', size: 1, type: 'float' }, { name: 'lutbakeMetalEta', size: 3, type: 'vec3' },
            { name: 'lutbakeMetalKappa', size: 3, type: 'vec3' }],
      fragment: 'uniform float lutbakeIor;\nuniform vec3 lutbakeMetalEta;\nuniform vec3 lutbakeMetalKappa;',
    };
  }

  bindForSubMesh(uniformBuffer) {
    uniformBuffer.updateFloat('lutbakeIor', this._material.indexOfRefraction);
    uniformBuffer.updateFloat3('lutbakeMetalEta', ...this.metal.eta);
    uniformBuffer.updateFloat3('lutbakeMetalKappa', ...this.metal.kappa);
    for (const [name, texture] of this.lutbakeTextures()) uniformBuffer.setTexture(name, texture);
  }

  getCustomCode(shaderType) {
    if (shaderType !== 'fragment') return null;
    const term = this.mode === 'runtime' ? 'lutbakeFilmFresnel(topIor,iridescenceIOR,viewAngle,iridescenceThickness)'
      : `lutbakeCapture(${CALL},viewAngle,iridescenceThickness,iridescenceIOR)`;
    const out = { 1: 'vec4(lutbakeFresnel, 1.0)', 2: 'vec4(lutbakeParameters, 1.0)',
                  3: 'vec4(lutbakeBaseColour, 1.0)', 4: 'vec4(vec3(lutbakeMetallic), 1.0)' }[OUTPUTS[this.output]];
    return {
      CUSTOM_FRAGMENT_DEFINITIONS: this.mode === 'runtime'
        ? definitions([this.runtime && this.runtime.include, this.bake && this.bake.include].filter(Boolean).join('\n'),
          this.bake ? this.bake.terms : RUNTIME_TERMS)
        : definitions(null, null),
      [`!${escape(CALL)};`]: `${term};`,  // Babylon appends a newline to injected code: keep the ';' on its line
      [`!${escape(BLOCK)}`]: `
#ifdef METALLICWORKFLOW
lutbakeMetallic=reflectivityOut.metallic;
#endif
lutbakeBaseColour=baseColor;
${BLOCK}`,
      CUSTOM_FRAGMENT_BEFORE_FRAGCOLOR: out ? `finalColor = ${out};` : '',
    };
  }
}

const DIELECTRIC_METAL = { eta: [1.5, 1.5, 1.5], kappa: [0, 0, 0] };

// Attach lutbake's term to a PBRMaterial (its iridescence must be enabled); returns the material. `bake`
// (lutbake-babylon-gltf.js: a glTF bake's routes) replaces the runtime table's terms by its own: { terms:
// {dielectric, metal}, include, atlas, lut, key } (the key names the terms for Babylon's effect cache).
export function lutbakeIridescence(material, { runtime = null, bake = null, mode = runtime || bake ? 'runtime' : 'babylon',
                                               metal = DIELECTRIC_METAL, output = null } = {}) {
  if (!(mode in MODES)) throw new Error(`lutbakeIridescence: mode '${mode}' is not one of ${Object.keys(MODES).join(', ')}`);
  if (mode === 'runtime' && !runtime && !bake) throw new Error("lutbakeIridescence: mode 'runtime' needs the runtime table");
  if (output !== null && !(output in OUTPUTS)) throw new Error(`lutbakeIridescence: output '${output}' is not one of ${Object.keys(OUTPUTS).join(', ')}`);
  if (!pbrBlockIridescence.shader.includes(CALL)) {
    throw new Error('lutbakeIridescence: Babylon.js changed pbrBlockIridescence (its evalIridescence call is not found)');
  }
  material.lutbakeIridescence = new LutbakeIridescencePlugin(material, { runtime, mode, metal, output, bake });
  return material;
}
