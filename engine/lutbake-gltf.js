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
// plugin too. `output` (tests): 'fresnel' writes material.iridescenceFresnel, 'parameters' (cos theta,
// thickness nm, metalness, iridescence), 'basecolor' the base colour the metal part was mapped from.
import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { loadLutbakeLut } from './lutbake-iridescence.js';

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
  const bake = { manifest, stem: manifest.scene.replace(/\.[^.]*$/, ''), atlas: null, atlasInclude: '', luts: {} };
  for (const entry of Object.values(manifest.materials)) {
    if (entry.kind === 'slice' && !bake.atlas) {
      bake.atlas = await new EXRLoader().loadAsync(folder + entry.file);
      bake.atlasInclude = await loadText(folder + entry.file.replace(/\.exr$/, '.glsl'));
    } else if (entry.kind === 'lut' && !bake.luts[entry.file]) {
      bake.luts[entry.file] = await loadLutbakeLut(folder + entry.file.replace(/\.exr$/, ''));
    }
  }
  return bake;
}

// The constant lutbake's atlas include defines for a material of the scene (lutfile.shader_ident).
function sliceIdent(stem, material) {
  const ident = `${stem}_${material}`.replace(/[^A-Za-z0-9]/g, '_').toUpperCase();
  return ident.startsWith('LUTBAKE_') ? ident : `LUTBAKE_${ident}`;
}

const OUTPUTS = {
  fresnel: 'vec4(material.iridescenceFresnel, 1.0)',
  parameters: 'vec4(dotNVi, material.iridescenceThickness, material.metalness, material.iridescence)',
  basecolor: 'vec4(material.diffuseColor, 1.0)',
};

// GLSL for one part's film term at (dotNVi, material.iridescenceThickness), with the declarations it needs.
function partTerm(bake, part) {
  const atlas = (name) => `lutbake_atlas_sample(lutbakeAtlas, ${sliceIdent(bake.stem, name)}, dotNVi, material.iridescenceThickness)`;
  if (part.material) return { call: atlas(part.material), lut: null };
  const entry = bake.manifest.materials[part.channels[0]];
  if (entry.kind === 'slice') {
    return { call: `vec3(${part.channels.map((name, c) => `${atlas(name)}.${'rgb'[c]}`).join(', ')})`, lut: null };
  }
  return { call: 'lutbakeTexturedMetal(material.diffuseColor, dotNVi, material.iridescenceThickness)',
           lut: bake.luts[entry.file], table: part.table };
}

// The 4D LUT of a texture-driven metal, read per channel at the mapping table's (eta3, kappa3) for that
// channel's base colour: the table's F0 nodes are uniform from 0 to its last.
function texturedMetalGlsl(lut, nodes) {
  return `uniform highp vec2 lutbakeMetalTable[${nodes}];
uniform highp float lutbakeMetalF0Max;
highp vec2 lutbakeConductor(highp float f0) {
  highp float x = clamp(f0 / lutbakeMetalF0Max, 0.0, 1.0) * ${(nodes - 1).toFixed(1)};
  int i = min(int(x), ${nodes - 2});
  return mix(lutbakeMetalTable[i], lutbakeMetalTable[i + 1], x - float(i));
}
highp vec3 lutbakeTexturedMetal(highp vec3 f0, highp float cosTheta, highp float thickness) {
  highp float opd = 2.0 * ${lut.ident}.eta2 * thickness;
  highp vec2 r = lutbakeConductor(f0.r), g = lutbakeConductor(f0.g), b = lutbakeConductor(f0.b);
  return vec3(lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, r.x, r.y).r,
              lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, g.x, g.y).g,
              lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, b.x, b.y).b);
}`;
}

// Patch a MeshPhysicalMaterial loaded from glTF material `record.gltf_index` (its manifest record).
export function lutbakeGltfMaterial(material, record, bake, output = null) {
  const terms = {};
  for (const [name, part] of Object.entries(record.parts)) terms[name] = partTerm(bake, part);
  const metal = terms.metal && terms.metal.lut ? terms.metal : null;
  material.onBeforeCompile = (shader) => {
    let begin = THREE.ShaderChunk.lights_fragment_begin;
    const calls = { dielectric: 'material.specularColor', metal: 'material.diffuseColor' };
    for (const [name, base] of Object.entries(calls)) {
      const three = `evalIridescence( 1.0, material.iridescenceIOR, dotNVi, material.iridescenceThickness, ${base} )`;
      if (!begin.includes(three)) throw new Error('lutbakeGltfMaterial: three.js changed lights_fragment_begin');
      if (terms[name]) begin = begin.replace(three, terms[name].call);
    }
    const declarations = ['uniform highp sampler2D lutbakeAtlas;', 'uniform highp sampler2D lutbakeLut;', bake.atlasInclude];
    shader.uniforms.lutbakeAtlas = { value: bake.atlas };
    shader.uniforms.lutbakeLut = { value: metal ? metal.lut.table : null };
    if (metal) {
      const { f0, eta3, kappa3 } = metal.table;
      shader.uniforms.lutbakeMetalTable = { value: f0.map((_, i) => new THREE.Vector2(eta3[i], kappa3[i])) };
      shader.uniforms.lutbakeMetalF0Max = { value: f0[f0.length - 1] };
      declarations.push(metal.lut.include, texturedMetalGlsl(metal.lut, f0.length));
    }
    let fragment = shader.fragmentShader
      .replace('#include <iridescence_fragment>', `#include <iridescence_fragment>\n${declarations.join('\n')}`)
      .replace('#include <lights_fragment_begin>', begin);
    if (output) fragment = fragment.replace('#include <dithering_fragment>', `#include <dithering_fragment>\n  gl_FragColor = ${OUTPUTS[output]};`);
    shader.fragmentShader = fragment;
  };
  // Programs are cached by this key: each glTF material's patch is its own program.
  material.customProgramCacheKey = () => `lutbake-gltf:${bake.stem}:${record.gltf_index}:${output}`;
  material.needsUpdate = true;
  return material;
}

// The GLTFLoader plugin: every glTF material the bake served is loaded by the parser as usual, then patched:
// as it is loaded (so variants loaded later are too) and, after the scene is built, on each mesh whose
// material GLTFLoader cloned (it clones for derivative tangents, vertex colours, flat shading, and a clone
// does not keep onBeforeCompile).
export class LutbakeGLTFPlugin {
  constructor(parser, bake, { output = null } = {}) {
    this.name = 'lutbake_iridescence';
    this.parser = parser;
    this.bake = bake;
    this.output = output;
    this.patched = new WeakSet();
    this.records = new Map(bake.manifest.source.materials
      .filter((r) => Object.keys(r.parts).length > 0).map((r) => [r.gltf_index, r]));
  }

  patch(material, index) {
    const record = this.records.get(index);
    if (record && !this.patched.has(material)) {
      lutbakeGltfMaterial(material, record, this.bake, this.output);
      this.patched.add(material);
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
