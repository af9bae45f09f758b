// lutbake for glTF assets in three.js: a GLTFLoader plugin that replaces each KHR_materials_iridescence
// material's thin-film Fresnel term (three's evalIridescence) by what `lutbake bake --gltf` baked for it
// (docs/gltf.md). The asset itself is unchanged; the bake's manifest says, per glTF material, which atlas
// slice serves its dielectric part and which serve its metal part (one per channel, or a 4D LUT read at the
// (eta3, kappa3) the mapping table gives each texel's base colour). three.js mixes the two parts by
// metalness, as it mixes its own.
//
//   import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
//   import { loadLutbakeBake, LutbakeGLTFPlugin } from './lutbake-gltf.js';
//   const bake = await loadLutbakeBake('build/iridescence/IridescenceLamp.json');   // the bake's manifest
//   const loader = new GLTFLoader().register((parser) => new LutbakeGLTFPlugin(parser, bake));
//   const gltf = await loader.loadAsync('IridescenceLamp.gltf');
//
// Materials loaded later (KHR_materials_variants: parser.getDependency('material', i)) go through the
// plugin too. Materials differ by uniforms, not shader source: their film index, base, slices and constants
// are uniforms, so every material whose parts take the same routes through the same atlas, LUT or runtime
// table shares one program (49 spheres of one grid: 2 programs, docs/engines.md).
// `output` (tests): 'fresnel' writes material.iridescenceFresnel, 'parameters' (cos theta,
// thickness nm, metalness, iridescence), 'basecolor' the base colour the metal part was mapped from.
//
// The runtime table (`lutbake runtime-table`, loadLutbakeRuntime) serves any film and base with no bake: pass
// it as `{ runtime }` and each part the file set does not cover (its slice or LUT absent from the manifest,
// or the manifest's entry `kind: "runtime"`: handed to the runtime path) is evaluated from it at the part's
// mapped base; `{ runtime, serve: 'runtime' }` serves every part so. With no bake at all, the mapping comes
// from `lutbake plan --gltf ASSET --json` (loadLutbakePlan). What served each part is material.userData.lutbake
// and plugin.served (glTF material index -> {gltfIndex, name, parts: {dielectric|metal: 'slice'|'lut'|'runtime'}}).
//
//   const runtime = await loadLutbakeRuntime('luts/runtime/lutbake-runtime', { renderer });   // float32 where the
//   // context filters it, else half: runtime.precision says which (lutbake-iridescence.js)
//   const plan = await loadLutbakePlan('Lamp.plan.json');        // lutbake plan --gltf Lamp.gltf --json > Lamp.plan.json
//   loader.register((parser) => new LutbakeGLTFPlugin(parser, plan, { runtime }));
import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { loadLutbakeLut } from './lutbake-iridescence.js';
import { metalTable, partRoute, sliceIdent } from './lutbake-routes.js';

async function loadText(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.text();
}

// The manifest of a glTF bake and every file it binds: the atlas (EXRLoader's defaults: half float,
// bilinear) with its include, and each 4D LUT with its include.
export async function loadLutbakeBake(manifestUrl) {
  const folder = manifestUrl.slice(0, manifestUrl.lastIndexOf('/') + 1);
  const manifest = JSON.parse(await loadText(manifestUrl));
  if (!manifest.source || manifest.source.kind !== 'gltf') throw new Error(`${manifestUrl}: not a lutbake glTF bake`);
  const bake = { manifest, stem: manifest.scene.replace(/\.[^.]*$/, ''), atlas: null, atlasInclude: '', slices: {},
                 luts: {}, records: manifest.source.materials.map((record) => withMetalTables(manifest, record)) };
  for (const entry of Object.values(manifest.materials)) {
    if (entry.kind === 'slice' && !bake.atlas) {
      bake.atlas = await new EXRLoader().loadAsync(folder + entry.file);
      bake.atlasInclude = await loadText(folder + entry.file.replace(/\.exr$/, '.glsl'));
      bake.slices = atlasSlices(bake.atlasInclude);
    } else if (entry.kind === 'lut' && !bake.luts[entry.file]) {
      bake.luts[entry.file] = await loadLutbakeLut(folder + entry.file.replace(/\.exr$/, ''));
    }
  }
  return bake;
}

// A texture-driven metal's part names its F0 -> (eta3, kappa3) table, written once at the manifest's top level
// (manifest.metal_tables: one per metal mapping); the record as the plugin reads it holds the table itself,
// read and checked by lutbake-routes.js metalTable.
function withMetalTables(manifest, record) {
  const parts = Object.fromEntries(Object.entries(record.parts).map(([name, part]) => {
    if (part.table === undefined) return [name, part];
    try {
      return [name, { ...part, table: metalTable(manifest, part) }];
    } catch (e) {
      throw new Error(`glTF material ${record.gltf_index} '${record.name}': ${e.message}`);
    }
  }));
  return { ...record, parts };
}

// `lutbake plan --gltf ASSET --json`: each material's mapping (film, thickness, bases) and no baked file, so
// the plugin serves every part from the runtime table.
export async function loadLutbakePlan(planUrl) {
  const plan = JSON.parse(await loadText(planUrl));
  if (!Array.isArray(plan.gltf_materials)) throw new Error(`${planUrl}: not a lutbake plan of a glTF asset (plan --gltf --json)`);
  return { manifest: { materials: {} }, stem: plan.scene.replace(/\.[^.]*$/, ''), atlas: null, atlasInclude: '', slices: {}, luts: {},
           records: plan.gltf_materials.map((r) => ({ ...r, parts: r.bases || {} })) };
}

// The slices lutbake's atlas include defines (`const LutbakeSlice NAME = LutbakeSlice(vec4(..), vec2(..),
// vec2(..));`), by constant name: {rect, thickness_nm, atlas_size}, the values a material's uniforms carry.
function atlasSlices(include) {
  const slices = {};
  const number = '(-?[0-9.eE+-]+)';
  const vec = (n) => `vec${n}\\(${Array(n).fill(number).join(', ')}\\)`;
  const line = new RegExp(`const LutbakeSlice (\\w+) = LutbakeSlice\\(${vec(4)}, ${vec(2)}, ${vec(2)}\\);`, 'g');
  for (const m of include.matchAll(line)) {
    const v = m.slice(2).map(Number);
    slices[m[1]] = { rect: new THREE.Vector4(...v.slice(0, 4)), thickness_nm: new THREE.Vector2(v[4], v[5]),
                     atlas_size: new THREE.Vector2(v[6], v[7]) };
  }
  return slices;
}

const OUTPUTS = {
  fresnel: 'vec4(material.iridescenceFresnel, 1.0)',
  parameters: 'vec4(dotNVi, material.iridescenceThickness, material.metalness, material.iridescence)',
  basecolor: 'vec4(material.diffuseColor, 1.0)',
};

// GLSL for one part's film term at (dotNVi, material.iridescenceThickness), by its route. The call reads the
// material's values (film index, base, slices, constant) from uniforms named for the part (`values`: this
// material's), never from literals: materials whose parts take the same routes through the same tables compile
// to the same source and share one program.
function partTerm(bake, record, name, part, route) {
  const at = 'dotNVi, material.iridescenceThickness';
  const u = name === 'dielectric' ? 'lutbakeDielectric' : 'lutbakeMetal';
  if (route === 'constant') {
    return { call: `${u}Constant`, uniforms: `uniform highp vec3 ${u}Constant;`,
             values: { [`${u}Constant`]: new THREE.Vector3(...part.constant) } };
  }
  if (route === 'runtime') {
    const film = `lutbakeRuntime, ${at}, 1.0, lutbakeFilm`;
    if (part.base) {
      return { call: `lutbake_iridescence(${film}, ${u}Base.x, ${u}Base.y)`, uniforms: `uniform highp vec2 ${u}Base;`,
               values: { [`${u}Base`]: new THREE.Vector2(...part.base) } };
    }
    if (part.table) return { call: `lutbakeRuntimeMetal(${film}, material.diffuseColor)`, table: part.table, values: {} };
    return { call: `lutbake_iridescence_rgb(${film}, ${u}Eta, ${u}Kappa)`,
             uniforms: `uniform highp vec3 ${u}Eta;\nuniform highp vec3 ${u}Kappa;`,
             values: { [`${u}Eta`]: new THREE.Vector3(...part.eta3), [`${u}Kappa`]: new THREE.Vector3(...part.kappa3) } };
  }
  const names = part.material ? [part.material] : part.channels;
  const entry = bake.manifest.materials[names[0]];
  if (entry.kind !== 'slice') {
    return { call: `lutbakeTexturedMetal(material.diffuseColor, ${at})`, lut: bake.luts[entry.file], table: part.table, values: {} };
  }
  const slices = names.map((material) => bake.slices[sliceIdent(bake.stem, material)]);
  if (slices.includes(undefined)) throw new Error(`glTF material ${record.gltf_index} '${record.name}': a slice of its ${name} part is not in the atlas include`);
  const read = (k) => `lutbake_atlas_sample(lutbakeAtlas, ${u}Slices[${k}], ${at})`;
  return { call: names.length === 1 ? read(0) : `vec3(${read(0)}.r, ${read(1)}.g, ${read(2)}.b)`,
           uniforms: `uniform LutbakeSlice ${u}Slices[${names.length}];`, values: { [`${u}Slices`]: slices } };
}

// A texture-driven metal's base per texel and channel: the mapping's F0 -> (eta3, kappa3) table, whose F0
// nodes are uniform from 0 to its last.
function conductorGlsl(nodes) {
  return `uniform highp vec2 lutbakeMetalTable[${nodes}];
uniform highp float lutbakeMetalF0Max;
highp vec2 lutbakeConductor(highp float f0) {
  highp float x = clamp(f0 / lutbakeMetalF0Max, 0.0, 1.0) * ${(nodes - 1).toFixed(1)};
  int i = min(int(x), ${nodes - 2});
  return mix(lutbakeMetalTable[i], lutbakeMetalTable[i + 1], x - float(i));
}`;
}

// The 4D LUT of a texture-driven metal, read per channel at that channel's base.
function texturedMetalGlsl(lut) {
  return `highp vec3 lutbakeTexturedMetal(highp vec3 f0, highp float cosTheta, highp float thickness) {
  highp float opd = 2.0 * ${lut.ident}.eta2 * thickness;
  highp vec2 r = lutbakeConductor(f0.r), g = lutbakeConductor(f0.g), b = lutbakeConductor(f0.b);
  return vec3(lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, r.x, r.y).r,
              lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, g.x, g.y).g,
              lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, b.x, b.y).b);
}`;
}

// The runtime table at a texture-driven metal's per-channel base: one read set for all three channels.
const RUNTIME_METAL_GLSL = `highp vec3 lutbakeRuntimeMetal(highp sampler2D table, highp float cosTheta, highp float thickness,
                                highp float eta1, highp float eta2, highp vec3 f0) {
  highp vec2 r = lutbakeConductor(f0.r), g = lutbakeConductor(f0.g), b = lutbakeConductor(f0.b);
  return lutbake_iridescence_rgb(table, cosTheta, thickness, eta1, eta2, vec3(r.x, g.x, b.x), vec3(r.y, g.y, b.y));
}`;

// cyrb53: a 53-bit hash of the GLSL a patch adds, the part of the program cache key that names its source.
function sourceHash(text) {
  let h1 = 0xdeadbeef, h2 = 0x41c6ce57;
  for (let i = 0; i < text.length; i++) {
    const c = text.charCodeAt(i);
    h1 = Math.imul(h1 ^ c, 2654435761);
    h2 = Math.imul(h2 ^ c, 1597334677);
  }
  h1 = Math.imul(h1 ^ (h1 >>> 16), 2246822507) ^ Math.imul(h2 ^ (h2 >>> 13), 3266489909);
  h2 = Math.imul(h2 ^ (h2 >>> 16), 2246822507) ^ Math.imul(h1 ^ (h1 >>> 13), 3266489909);
  return (4294967296 * (2097151 & h2) + (h1 >>> 0)).toString(36);
}

// The GLSL a material's patch adds to three's fragment shader (declarations, lights_fragment_begin with the
// parts' terms, the test output): a function of the parts' routes and tables only, never of the material's values.
// A part the record lacks has weight 0 wherever three mixes the two (the bake keeps a part wherever the
// material's metalness needs it): its term is vec3(0.0), and three's own evalIridescence is not compiled.
function patchGlsl(bake, terms, runtime, output) {
  let begin = THREE.ShaderChunk.lights_fragment_begin;
  const calls = { dielectric: 'material.specularColor', metal: 'material.diffuseColor' };
  for (const [name, base] of Object.entries(calls)) {
    const three = `evalIridescence( 1.0, material.iridescenceIOR, dotNVi, material.iridescenceThickness, ${base} )`;
    if (!begin.includes(three)) throw new Error('lutbakeGltfMaterial: three.js changed lights_fragment_begin');
    begin = begin.replace(three, terms[name] ? terms[name].call : 'vec3(0.0)');
  }
  const lutTerm = Object.values(terms).find((term) => term.lut);
  const table = Object.values(terms).find((term) => term.table);
  const declarations = ['uniform highp sampler2D lutbakeAtlas;', 'uniform highp sampler2D lutbakeLut;', bake.atlasInclude];
  if (runtime) declarations.push('uniform highp sampler2D lutbakeRuntime;', 'uniform highp float lutbakeFilm;', runtime.include);
  declarations.push(...Object.values(terms).filter((term) => term.uniforms).map((term) => term.uniforms));
  if (table) declarations.push(conductorGlsl(table.table.f0.length));
  if (lutTerm) declarations.push(lutTerm.lut.include, texturedMetalGlsl(lutTerm.lut));
  if (table && !lutTerm) declarations.push(RUNTIME_METAL_GLSL);
  const tail = output ? `#include <dithering_fragment>\n  gl_FragColor = ${OUTPUTS[output]};` : null;
  return { declarations: declarations.join('\n'), begin, tail };
}

// This material's uniform values: the tables it reads and the values its parts' terms name.
function patchUniforms(bake, record, terms, runtime) {
  const lutTerm = Object.values(terms).find((term) => term.lut);
  const table = Object.values(terms).find((term) => term.table);
  const values = { lutbakeAtlas: bake.atlas, lutbakeLut: lutTerm ? lutTerm.lut.table : null,
                   ...Object.assign({}, ...Object.values(terms).map((term) => term.values)) };
  if (runtime) Object.assign(values, { lutbakeRuntime: runtime.table, lutbakeFilm: record.film });
  if (table) {
    const { f0, eta3, kappa3 } = table.table;
    values.lutbakeMetalTable = f0.map((_, i) => new THREE.Vector2(eta3[i], kappa3[i]));
    values.lutbakeMetalF0Max = f0[f0.length - 1];
  }
  return values;
}

// Patch a MeshPhysicalMaterial loaded from glTF material `record.gltf_index` (its manifest or plan record):
// each part by its route (partRoute), recorded in material.userData.lutbake. The material's film index, base,
// slices and constant are uniforms: three.js caches programs by customProgramCacheKey, here the routes and a hash
// of the added GLSL, so materials on the same routes through the same atlas, LUT or runtime table share a program.
export function lutbakeGltfMaterial(material, record, bake, { output = null, runtime = null, serve = 'bake' } = {}) {
  const terms = {}, routes = {};
  for (const [name, part] of Object.entries(record.parts)) {
    routes[name] = partRoute(bake, part, serve);
    if (routes[name] === null) throw new Error(`glTF material ${record.gltf_index} '${record.name}': its named metal is not in the bake`);
    if (routes[name] === 'runtime' && !runtime) {
      throw new Error(`glTF material ${record.gltf_index} '${record.name}': its ${name} part is not baked; pass { runtime } (loadLutbakeRuntime)`);
    }
    terms[name] = partTerm(bake, record, name, part, routes[name]);
  }
  const glsl = patchGlsl(bake, terms, runtime, output);
  const values = patchUniforms(bake, record, terms, runtime);
  material.onBeforeCompile = (shader) => {
    for (const [name, value] of Object.entries(values)) shader.uniforms[name] = { value };
    let fragment = shader.fragmentShader
      .replace('#include <iridescence_fragment>', `#include <iridescence_fragment>\n${glsl.declarations}`)
      .replace('#include <lights_fragment_begin>', glsl.begin);
    if (glsl.tail) fragment = fragment.replace('#include <dithering_fragment>', glsl.tail);
    shader.fragmentShader = fragment;
  };
  const routeKey = Object.entries(routes).map((r) => r.join('=')).join(',');
  const key = `lutbake-gltf:${routeKey}:${sourceHash(glsl.declarations + glsl.begin + (glsl.tail ?? ''))}`;
  material.customProgramCacheKey = () => key;
  material.userData.lutbake = { gltfIndex: record.gltf_index, name: record.name, parts: routes };
  material.needsUpdate = true;
  return material;
}

// The GLTFLoader plugin: every glTF material the bake served is loaded by the parser as usual, then patched:
// as it is loaded (so variants loaded later are too) and, after the scene is built, on each mesh whose
// material GLTFLoader cloned (it clones for derivative tangents, vertex colours, flat shading, and a clone
// does not keep onBeforeCompile).
export class LutbakeGLTFPlugin {
  constructor(parser, bake, { output = null, runtime = null, serve = 'bake' } = {}) {
    if (!['bake', 'runtime'].includes(serve)) throw new Error(`LutbakeGLTFPlugin: serve '${serve}' is not 'bake' or 'runtime'`);
    if (serve === 'runtime' && !runtime) throw new Error("LutbakeGLTFPlugin: serve 'runtime' needs { runtime } (loadLutbakeRuntime)");
    this.name = 'lutbake_iridescence';
    this.parser = parser;
    this.bake = bake;
    this.options = { output, runtime, serve };
    this.patched = new WeakSet();
    this.served = new Map();
    this.records = new Map(bake.records.filter((r) => Object.keys(r.parts).length > 0).map((r) => [r.gltf_index, r]));
  }

  patch(material, index) {
    const record = this.records.get(index);
    if (record && !this.patched.has(material)) {
      lutbakeGltfMaterial(material, record, this.bake, this.options);
      this.patched.add(material);
      this.served.set(index, material.userData.lutbake);
    }
    return material;
  }

  loadMaterial(materialIndex) {
    if (!this.records.has(materialIndex)) return null;   // not iridescent, unused or no film: the parser's own
    return this.parser.loadMaterial(materialIndex).then((material) => this.patch(material, materialIndex));
  }

  afterRoot(result) {
    result.scene.traverse((object) => {
      if (!object.isMesh) return;
      for (const material of [].concat(object.material)) {
        const association = this.parser.associations.get(material);
        if (association && association.materials !== undefined) this.patch(material, association.materials);
      }
    });
    return null;
  }
}
