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
// Baked glTF outputs (`lutbake bake --gltf`: atlases and 4D LUTs) are served in three.js only
// (engine/lutbake-gltf.js); in Babylon every material is served from the runtime table.
import { registerGLTFExtension, unregisterGLTFExtension } from '@babylonjs/loaders/glTF/2.0/glTFLoaderExtensionRegistry.js';
import { lutbakeIridescence } from './lutbake-babylon.js';

export const NAME = 'lutbake_iridescence';

class LutbakeGltfExtension {
  constructor(loader) {
    this.name = NAME;
    const options = loader.parent.extensionOptions[NAME] || {};
    this.enabled = Boolean(options.runtime);
    this.served = {};
    if (!this.enabled) return;
    const { runtime, metals = {}, output = null } = options;
    // Every material the loader creates (variants included), before its properties load: the plugin reads
    // the iridescence settings when the shader is built, so it is inert on materials without iridescence.
    this._observer = loader.parent.onMaterialLoadedObservable.add((material) => {
      if (!material.iridescence) return;
      lutbakeIridescence(material, { runtime, metal: metals[material.name] || undefined, output });
      this.served[material.name] = metals[material.name] ? 'runtime, metal per channel' : 'runtime';
    });
    this._loader = loader;
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
