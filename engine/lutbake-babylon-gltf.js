// lutbake for glTF assets in Babylon.js: a glTF loader extension (@babylonjs/loaders 9, pinned) that serves
// every KHR_materials_iridescence material of an asset from lutbake's runtime table, through the PBRMaterial
// plugin of lutbake-babylon.js. The asset is unchanged: Babylon's own KHR_materials_iridescence and
// KHR_materials_ior extensions still load the film (index, thickness range and texture) and the base's index;
// the plugin replaces only the term. A metallic material's base needs n, k per channel, which glTF does not
// carry: `metals` maps a glTF material's name to them (lutbake's named metals: exact.base_rgb; or the
// per-material bases `lutbake plan --gltf ASSET --json` maps). Materials without a name there are
// evaluated over a dielectric base of index 1.5 where metallic.
//
//   import { registerLutbakeGltf } from './lutbake-babylon-gltf.js';
//   import { loadLutbakeRuntime } from './lutbake-babylon.js';
//   registerLutbakeGltf();                                                   // once
//   const runtime = await loadLutbakeRuntime('luts/runtime/lutbake-runtime', scene);
//   const container = await LoadAssetContainerAsync('IridescenceLamp.gltf', scene, { pluginOptions: { gltf: {
//     extensionOptions: { lutbake_iridescence: { runtime, metals: { 'Lamp metal': { eta: [...], kappa: [...] } } } } } } });
//
// A `lutbake bake --gltf` output is served as engine/lutbake-gltf.js serves it in three.js (docs/gltf.md):
// pass `bake` (loadLutbakeBakeBabylon) and each glTF material the manifest records is served, part by part
// (dielectric, metal: mixed by the material's metallic value), by the route lutbake-routes.js picks: its atlas
// slice, one slice per channel, the runtime table (`runtime` needed; `serve: 'runtime'` sends every part there)
// or a constant; a texture-driven metal (a base colour texture on a metal) at each pixel's base colour
// (Babylon's baseColor: albedo factor x texture x vertex colour) through the mapping's F0 table, its 4D LUT
// or the runtime table. What served each material: material.metadata.lutbake ({gltfIndex, name, parts: {dielectric|metal: route}}).
//
//   const bake = await loadLutbakeBakeBabylon('build/Lamp/IridescenceLamp.json', scene);
//   ... extensionOptions: { lutbake_iridescence: { bake, runtime } } ...
import { registerGLTFExtension, unregisterGLTFExtension } from '@babylonjs/loaders/glTF/2.0/glTFLoaderExtensionRegistry.js';
import { lutbakeIridescence, lutbakeTexture } from './lutbake-babylon.js';
import { SERVES, bakeTerms, loadBakeManifest, partRoutes } from './lutbake-routes.js';

export const NAME = 'lutbake_iridescence';

// The manifest of a glTF bake with its atlas (if any slice serves a part) and 4D LUTs as Babylon textures.
export function loadLutbakeBakeBabylon(manifestUrl, scene) {
  return loadBakeManifest(manifestUrl, (table) => lutbakeTexture(table, scene));
}

class LutbakeGltfExtension {
  constructor(loader) {
    this.name = NAME;
    const options = loader.parent.extensionOptions[NAME] || {};
    this.enabled = Boolean(options.runtime || options.bake);
    this.served = {};
    this.options = { serve: 'bake', ...options };
    this._loader = loader;
    if (!SERVES.includes(this.options.serve)) throw new Error(`lutbake_iridescence: serve '${this.options.serve}' is not ${SERVES.join(' or ')}`);
    if (!this.enabled || options.bake) return;
    const { runtime, metals = {}, output = null } = options;
    // Every material the loader creates (variants included), before its properties load: the plugin reads
    // the iridescence settings when the shader is built, so it is inert on materials without iridescence.
    this._observer = loader.parent.onMaterialLoadedObservable.add((material) => {
      if (!material.iridescence) return;
      lutbakeIridescence(material, { runtime, metal: metals[material.name] || undefined, output });
      this.served[material.name] = metals[material.name] ? 'runtime, metal per channel' : 'runtime';
    });
  }

  // With a bake: each glTF material (by its index) the manifest records, once Babylon loaded its properties.
  loadMaterialPropertiesAsync(context, material, babylonMaterial) {
    const { bake, runtime = null, serve, output = null } = this.options;
    const record = bake && bake.records.get(material.index);
    if (!record) return null;
    return this._loader.loadMaterialPropertiesAsync(context, material, babylonMaterial).then(() => {
      const routes = partRoutes(bake, record, { runtime: Boolean(runtime), serve });
      lutbakeIridescence(babylonMaterial, { runtime, bake: bakeTerms(bake, record, routes), output });
      this.served[record.gltf_index] = { gltfIndex: record.gltf_index, name: record.name, parts: routes };
      babylonMaterial.metadata = { ...babylonMaterial.metadata, lutbake: this.served[record.gltf_index] };
    });
  }

  dispose() {
    if (this._observer) this._loader.parent.onMaterialLoadedObservable.remove(this._observer);
  }
}

// Register the extension with Babylon's glTF loader (not a glTF extension: it runs for every asset loaded
// with extensionOptions.lutbake_iridescence.runtime set). Returns the function that unregisters it.
export function registerLutbakeGltf() {
  registerGLTFExtension(NAME, false, (loader) => new LutbakeGltfExtension(loader));
  return () => unregisterGLTFExtension(NAME);
}
