// Which file serves each part of a glTF material in a `lutbake bake --gltf` output (docs/gltf.md), for any
// engine: the manifest's record of a glTF material names, per part (dielectric, metal), an atlas slice, one
// slice per channel, a 4D LUT, the runtime table (the part's entry absent or `kind: "runtime"`) or a constant
// (vacuum over vacuum); and each route as a GLSL term (bakeTerms) for the engine's file to compile
// (lutbake-babylon-gltf.js, lutbake-playcanvas.js). The three.js plugin (lutbake-gltf.js) takes its routes and
// slice names from here too and writes its own terms (uniforms, so that materials share programs).
// A texture-driven metal (a base colour texture on a metal: F0 per texel and channel) is read through its
// mapping's F0 -> (eta3, kappa3) table (metalTable, the one reader of where the manifest keeps it) at the
// pixel's base colour, which the engine's file provides as `lutbakeBaseColour`: its 4D LUT per channel, or the
// runtime table at the three channels' bases.
//
//   import { loadBakeManifest, partRoutes } from './lutbake-routes.js';
//   const bake = await loadBakeManifest('build/iridescence/IridescenceLamp.json', (table, name) => engineTexture(table));
//   const record = bake.records.get(gltfMaterialIndex);      // undefined: nothing to serve (not iridescent)
//   const routes = partRoutes(bake, record, { runtime: true, serve: 'bake' });  // {dielectric: 'slice', ...}
import { loadLutTable, loadSceneAtlas } from './lutbake-exr.js';

export const SERVES = ['bake', 'runtime'];

// The manifest of a glTF bake, the folder its files are in, the scene's stem (the atlas include's constants
// are named by it), the records of the glTF materials with something to serve, by glTF material index, the
// atlas where a slice serves a part (null if none) with its include, and each 4D LUT a texture-driven metal
// reads ({file: {texture, include, ident}}). `upload(table, name)` makes the engine's texture of a table's
// RGBA half texels ({width, height, texels}, scanline 0 first: lutbake-exr.js).
export async function loadBakeManifest(manifestUrl, upload) {
  const response = await fetch(manifestUrl);
  if (!response.ok) throw new Error(`${manifestUrl}: HTTP ${response.status}`);
  const manifest = await response.json();
  if (!manifest.source || manifest.source.kind !== 'gltf') throw new Error(`${manifestUrl}: not a lutbake glTF bake`);
  const served = manifest.source.materials.filter((r) => Object.keys(r.parts).length > 0);
  const folder = manifestUrl.slice(0, manifestUrl.lastIndexOf('/') + 1);
  const stem = (entry) => folder + entry.file.replace(/\.exr$/, '');
  const slice = Object.values(manifest.materials).find((entry) => entry.kind === 'slice');
  const atlas = slice ? await loadSceneAtlas(stem(slice)) : null;
  const luts = {};
  for (const entry of Object.values(manifest.materials).filter((e) => e.kind === 'lut' && !(e.file in luts))) {
    const lut = await loadLutTable(stem(entry));
    luts[entry.file] = { texture: upload(lut, entry.file), include: lut.include, ident: lut.ident };
  }
  return { manifest, folder, stem: manifest.scene.replace(/\.[^.]*$/, ''), atlas: atlas && upload(atlas, slice.file),
           include: atlas ? atlas.include : '', luts, records: new Map(served.map((r) => [r.gltf_index, r])) };
}

// A texture-driven metal's F0 -> (eta3, kappa3) table: `entry` is the metal part of a glTF material's record
// (`texture: true`); its F0 nodes run uniformly from 0 to f0Max (the mapping's curve, clamped past its end).
// Engine code reads the table only through here: the part holds it, or names one of the manifest's
// top-level `metal_tables` (one per mapping).
export function metalTable(manifest, entry) {
  const table = typeof entry.table === 'string' ? (manifest.metal_tables || {})[entry.table] : entry.table;
  if (!table) throw new Error(`metal table '${entry.table}' is not in the manifest's metal_tables`);
  const { f0, eta3, kappa3 } = table;
  const nodes = Array.isArray(f0) ? f0.length : 0;
  const valid = (a) => Array.isArray(a) && a.length === nodes && a.every(Number.isFinite);
  // the include interpolates between nodes i and i + 1: fewer than two would read outside its array
  if (nodes < 2 || ![f0, eta3, kappa3].every(valid)) {
    throw new Error(`metal table '${entry.table}': f0, eta3 and kappa3 must be arrays of at least 2 finite numbers, all of one length`);
  }
  return { f0, eta3, kappa3, f0Max: f0[nodes - 1] };
}

// The constant the atlas include defines for a slice of the scene (lutfile.shader_ident).
export function sliceIdent(stem, material) {
  const ident = `${stem}_${material}`.replace(/[^A-Za-z0-9]/g, '_').toUpperCase();
  return ident.startsWith('LUTBAKE_') ? ident : `LUTBAKE_${ident}`;
}

// One part's route: 'constant', 'slice', 'lut' or 'runtime' ('runtime' where the bake does not cover the part,
// where its entry hands it to the runtime path, or where `serve` is 'runtime'); null for a named metal the bake
// lacks (its spectral index has no per-channel (eta3, kappa3) for the runtime table).
export function partRoute(bake, part, serve) {
  if (part.constant) return 'constant';   // vacuum over vacuum: the film term is 0, nothing baked
  const entries = (part.material ? [part.material] : part.channels || []).map((m) => bake.manifest.materials[m]);
  const baked = entries.every((entry) => entry && entry.kind !== 'runtime');
  if (part.mapping === 'named') return baked ? entries[0].kind : null;
  return serve === 'runtime' || !baked ? 'runtime' : entries[0].kind;
}

// Every part's route of one record; throws, naming the material, where a part cannot be served.
export function partRoutes(bake, record, { runtime = false, serve = 'bake' } = {}) {
  const routes = {};
  for (const [name, part] of Object.entries(record.parts)) {
    routes[name] = partRoute(bake, part, serve);
    const what = `glTF material ${record.gltf_index} '${record.name}'`;
    if (routes[name] === null) throw new Error(`${what}: its named metal is not in the bake`);
    if (routes[name] === 'runtime' && !runtime) throw new Error(`${what}: its ${name} part is not baked; pass the runtime table`);
  }
  return routes;
}

// A manifest number as a GLSL literal; anything else (a string, null) would be pasted into the shader's source.
const glslFloat = (x) => {
  if (!Number.isFinite(x)) throw new Error(`manifest value ${JSON.stringify(x)} is not a finite number`);
  return Number.isInteger(x) ? x.toFixed(1) : String(x);
};
const glslVec3 = (v) => `vec3(${v.map(glslFloat).join(', ')})`;

// One part's film term by its route: a GLSL expression in (cosTheta, thicknessNm) reading the samplers
// lutbakeAtlas (the bake's atlas, its include compiled) and lutbakeTable (the runtime table, its include),
// at the film the bake recorded over the ambient index 1 (the bake's model). A texture-driven metal's term
// calls lutbakeTexturedMetal (texturedMetalGlsl) at the pixel's base colour.
function partTerm(bake, record, part, route) {
  const at = 'cosTheta, thicknessNm';
  const film = `${at}, 1.0, ${glslFloat(record.film)}`;
  if (route === 'constant') return glslVec3(part.constant);
  if (part.texture && ['lut', 'runtime'].includes(route)) return `lutbakeTexturedMetal(lutbakeBaseColour, ${at})`;
  if (route === 'runtime' && part.base) return `lutbake_iridescence(lutbakeTable, ${film}, ${part.base.map(glslFloat).join(', ')})`;
  if (route === 'runtime' && part.eta3) return `lutbake_iridescence_rgb(lutbakeTable, ${film}, ${glslVec3(part.eta3)}, ${glslVec3(part.kappa3)})`;
  const atlas = (name) => `lutbake_atlas_sample(lutbakeAtlas, ${sliceIdent(bake.stem, name)}, ${at})`;
  if (route === 'slice' && part.material) return atlas(part.material);
  if (route === 'slice') return `vec3(${part.channels.map((name, c) => `${atlas(name)}.${'rgb'[c]}`).join(', ')})`;
  throw new Error(`glTF material ${record.gltf_index} '${record.name}': its ${route} route has no base to read (not a texture-driven metal)`);
}

// A texture-driven metal's lutbakeTexturedMetal(f0, cosTheta, thicknessNm): each channel's base from the F0
// table (metalTable: linear between its nodes, clamped at its ends), then its 4D LUT per channel (sampler
// lutbakeLut) or the runtime table at the three bases; with the include that reads it ('' for the runtime
// table's, the engine's). The table is a constant array: these terms are compiled per material anyway.
function texturedMetalGlsl(bake, record, part, route) {
  const { f0, eta3, kappa3, f0Max } = metalTable(bake.manifest, part);
  const nodes = f0.length;
  const pairs = f0.map((_, i) => `vec2(${glslFloat(eta3[i])}, ${glslFloat(kappa3[i])})`).join(',\n  ');
  const bases = 'highp vec2 r = lutbakeConductor(f0.r), g = lutbakeConductor(f0.g), b = lutbakeConductor(f0.b);';
  const conductor = `const highp vec2 LUTBAKE_METAL_TABLE[${nodes}] = vec2[${nodes}](
  ${pairs});
highp vec2 lutbakeConductor(highp float f0) {
  highp float x = clamp(f0 / ${glslFloat(f0Max)}, 0.0, 1.0) * ${glslFloat(nodes - 1)};
  int i = min(int(x), ${nodes - 2});
  return mix(LUTBAKE_METAL_TABLE[i], LUTBAKE_METAL_TABLE[i + 1], x - float(i));
}
highp vec3 lutbakeTexturedMetal(highp vec3 f0, highp float cosTheta, highp float thicknessNm) {
  ${bases}`;
  if (route === 'runtime') {
    return { include: '', glsl: `${conductor}
  return lutbake_iridescence_rgb(lutbakeTable, cosTheta, thicknessNm, 1.0, ${glslFloat(record.film)}, vec3(r.x, g.x, b.x), vec3(r.y, g.y, b.y));
}` };
  }
  const lut = bake.luts[bake.manifest.materials[part.channels[0]].file];
  const read = (c) => `lutbake_sample(lutbakeLut, ${lut.ident}, cosTheta, opd, ${c}.x, ${c}.y).${c}`;
  return { lut, include: lut.include, glsl: `${conductor}
  highp float opd = 2.0 * ${lut.ident}.eta2 * thicknessNm;
  return vec3(${['r', 'g', 'b'].map(read).join(', ')});
}` };
}

// One record's terms by part ({dielectric, metal}: GLSL expressions, mixed by the engine's metallic weight),
// with the GLSL they read (the bake's atlas include, a texture-driven metal's table and LUT include), the
// textures to bind (the atlas as lutbakeAtlas, a texture-driven metal's 4D LUT as lutbakeLut: null if none)
// and a key naming them for a shader cache.
export function bakeTerms(bake, record, routes) {
  const terms = Object.fromEntries(Object.entries(routes).map(([name, route]) => [name, partTerm(bake, record, record.parts[name], route)]));
  const metal = record.parts.metal;
  const textured = metal && metal.texture && ['lut', 'runtime'].includes(routes.metal) ? texturedMetalGlsl(bake, record, metal, routes.metal) : null;
  const include = [bake.include, textured && textured.include, textured && textured.glsl].filter(Boolean).join('\n');
  const key = `B${bake.manifest.scene_hash.slice(0, 16)}:${record.gltf_index}:${Object.entries(routes).join(',')}`.replace(/[^A-Za-z0-9_]/g, '_');
  return { terms, include, atlas: bake.atlas, lut: textured && textured.lut ? textured.lut.texture : null, key };
}
