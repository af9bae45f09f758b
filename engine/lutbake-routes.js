// Which file serves each part of a glTF material in a `lutbake bake --gltf` output (docs/gltf.md), for any
// engine: the manifest's record of a glTF material names, per part (dielectric, metal), an atlas slice, one
// slice per channel, a 4D LUT, the runtime table (the part's entry absent or `kind: "runtime"`) or a constant
// (vacuum over vacuum); and each route as a GLSL term (bakeTerms) for the engine's file to compile
// (lutbake-babylon-gltf.js, lutbake-playcanvas.js). The three.js plugin (lutbake-gltf.js) takes its routes and
// slice names from here too and writes its own terms (uniforms, so that materials share programs).
//
//   import { loadBakeManifest, partRoutes } from './lutbake-routes.js';
//   const bake = await loadBakeManifest('build/iridescence/IridescenceLamp.json');
//   const record = bake.records.get(gltfMaterialIndex);      // undefined: nothing to serve (not iridescent)
//   const routes = partRoutes(bake, record, { runtime: true, serve: 'bake' });  // {dielectric: 'slice', ...}
import { loadSceneAtlas } from './lutbake-exr.js';

export const SERVES = ['bake', 'runtime'];

// The manifest of a glTF bake, the folder its files are in, the scene's stem (the atlas include's constants
// are named by it), the records of the glTF materials with something to serve, by glTF material index, and
// the atlas where a slice serves a part (RGBA half texels, scanline 0 first: lutbake-exr.js; null if none)
// with its include (texels for the engine's file to upload).
export async function loadBakeManifest(manifestUrl) {
  const response = await fetch(manifestUrl);
  if (!response.ok) throw new Error(`${manifestUrl}: HTTP ${response.status}`);
  const manifest = await response.json();
  if (!manifest.source || manifest.source.kind !== 'gltf') throw new Error(`${manifestUrl}: not a lutbake glTF bake`);
  const served = manifest.source.materials.filter((r) => Object.keys(r.parts).length > 0);
  const folder = manifestUrl.slice(0, manifestUrl.lastIndexOf('/') + 1);
  const slice = Object.values(manifest.materials).find((entry) => entry.kind === 'slice');
  const atlas = slice ? await loadSceneAtlas(folder + slice.file.replace(/\.exr$/, '')) : null;
  return { manifest, folder, stem: manifest.scene.replace(/\.[^.]*$/, ''), atlas, include: atlas ? atlas.include : '',
           records: new Map(served.map((r) => [r.gltf_index, r])) };
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

const glslFloat = (x) => (Number.isInteger(x) ? x.toFixed(1) : String(x));
const glslVec3 = (v) => `vec3(${v.map(glslFloat).join(', ')})`;

// One part's film term by its route: a GLSL expression in (cosTheta, thicknessNm) reading the samplers
// lutbakeAtlas (the bake's atlas, its include compiled) and lutbakeTable (the runtime table, its include),
// at the film the bake recorded over the ambient index 1 (the bake's model). A texture-driven metal (a 4D
// LUT, or the runtime table per texel) is not served by these engines yet: it throws, naming the material.
function partTerm(bake, record, part, route) {
  const at = 'cosTheta, thicknessNm';
  const film = `${at}, 1.0, ${glslFloat(record.film)}`;
  if (route === 'constant') return glslVec3(part.constant);
  if (route === 'runtime' && part.base) return `lutbake_iridescence(lutbakeTable, ${film}, ${part.base.map(glslFloat).join(', ')})`;
  if (route === 'runtime' && part.eta3 && !part.table) {
    return `lutbake_iridescence_rgb(lutbakeTable, ${film}, ${glslVec3(part.eta3)}, ${glslVec3(part.kappa3)})`;
  }
  const atlas = (name) => `lutbake_atlas_sample(lutbakeAtlas, ${sliceIdent(bake.stem, name)}, ${at})`;
  if (route === 'slice' && part.material) return atlas(part.material);
  if (route === 'slice') return `vec3(${part.channels.map((name, c) => `${atlas(name)}.${'rgb'[c]}`).join(', ')})`;
  throw new Error(`glTF material ${record.gltf_index} '${record.name}': a texture-driven metal (route ${route}) is not served by these terms yet (Babylon.js, PlayCanvas; the three.js plugin serves it)`);
}

// One record's terms by part ({dielectric, metal}: GLSL expressions, mixed by the engine's metallic weight),
// with the bake's atlas and include (loaded by the engine's file) and a key naming them for a shader cache.
export function bakeTerms(bake, record, routes) {
  const terms = Object.fromEntries(Object.entries(routes).map(([name, route]) => [name, partTerm(bake, record, record.parts[name], route)]));
  const key = `B${bake.manifest.scene_hash.slice(0, 16)}:${record.gltf_index}:${Object.entries(routes).join(',')}`.replace(/[^A-Za-z0-9_]/g, '_');
  return { terms, include: bake.include, atlas: bake.atlas, key };
}
