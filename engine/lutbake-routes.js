// Which file serves each part of a glTF material in a `lutbake bake --gltf` output (docs/gltf.md), for any
// engine: the manifest's record of a glTF material names, per part (dielectric, metal), an atlas slice, one
// slice per channel, a 4D LUT, the runtime table (the part's entry absent or `kind: "runtime"`) or a constant
// (vacuum over vacuum). The engine's file turns each route into its shader code (lutbake-babylon-gltf.js).
//
//   import { loadBakeManifest, partRoutes } from './lutbake-routes.js';
//   const bake = await loadBakeManifest('build/iridescence/IridescenceLamp.json');
//   const record = bake.records.get(gltfMaterialIndex);      // undefined: nothing to serve (not iridescent)
//   const routes = partRoutes(bake, record, { runtime: true, serve: 'bake' });  // {dielectric: 'slice', ...}

export const SERVES = ['bake', 'runtime'];

// The manifest of a glTF bake, the folder its files are in, the scene's stem (the atlas include's constants
// are named by it) and the records of the glTF materials with something to serve, by glTF material index.
export async function loadBakeManifest(manifestUrl) {
  const response = await fetch(manifestUrl);
  if (!response.ok) throw new Error(`${manifestUrl}: HTTP ${response.status}`);
  const manifest = await response.json();
  if (!manifest.source || manifest.source.kind !== 'gltf') throw new Error(`${manifestUrl}: not a lutbake glTF bake`);
  const served = manifest.source.materials.filter((r) => Object.keys(r.parts).length > 0);
  return { manifest, folder: manifestUrl.slice(0, manifestUrl.lastIndexOf('/') + 1),
           stem: manifest.scene.replace(/\.[^.]*$/, ''), records: new Map(served.map((r) => [r.gltf_index, r])) };
}

// The constant the atlas include defines for a slice of the scene (lutfile.shader_ident).
export function sliceIdent(stem, material) {
  const ident = `${stem}_${material}`.replace(/[^A-Za-z0-9]/g, '_').toUpperCase();
  return ident.startsWith('LUTBAKE_') ? ident : `LUTBAKE_${ident}`;
}

// One part's route: 'constant', 'slice', 'lut' or 'runtime' ('runtime' where the bake does not cover the part,
// where its entry hands it to the runtime path, or where `serve` is 'runtime'); null for a named metal the bake
// lacks (its spectral index has no per-channel (eta3, kappa3) for the runtime table).
function partRoute(entries, part, serve) {
  if (part.constant) return 'constant';
  const baked = entries.every((entry) => entry && entry.kind !== 'runtime');
  if (part.mapping === 'named') return baked ? entries[0].kind : null;
  return serve === 'runtime' || !baked ? 'runtime' : entries[0].kind;
}

// Every part's route of one record; throws, naming the material, where a part cannot be served.
export function partRoutes(bake, record, { runtime = false, serve = 'bake' } = {}) {
  const routes = {};
  for (const [name, part] of Object.entries(record.parts)) {
    const entries = (part.material ? [part.material] : part.channels || []).map((m) => bake.manifest.materials[m]);
    routes[name] = partRoute(entries, part, serve);
    const what = `glTF material ${record.gltf_index} '${record.name}'`;
    if (routes[name] === null) throw new Error(`${what}: its named metal is not in the bake`);
    if (routes[name] === 'runtime' && !runtime) throw new Error(`${what}: its ${name} part is not baked; pass the runtime table`);
  }
  return routes;
}
