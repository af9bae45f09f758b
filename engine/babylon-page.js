// Babylon.js's PBRMaterial with lutbake's runtime table in headless Chromium (engine/harness.mjs babylon,
// tests/engines/test_babylon_engine.py): per material, a sphere rendered into a float target with the film's
// Fresnel term as output and again with the parameters each pixel used, for Babylon's own term and lutbake's.
import { Engine } from '@babylonjs/core/Engines/engine.js';
import { Scene } from '@babylonjs/core/scene.js';
import { Camera } from '@babylonjs/core/Cameras/camera.js';
import { FreeCamera } from '@babylonjs/core/Cameras/freeCamera.js';
import { Color3, Color4 } from '@babylonjs/core/Maths/math.color.js';
import { Vector3 } from '@babylonjs/core/Maths/math.vector.js';
import { DirectionalLight } from '@babylonjs/core/Lights/directionalLight.js';
import { CreateSphere } from '@babylonjs/core/Meshes/Builders/sphereBuilder.js';
import { PBRMaterial } from '@babylonjs/core/Materials/PBR/pbrMaterial.js';
import { RawTexture } from '@babylonjs/core/Materials/Textures/rawTexture.js';
import { Texture } from '@babylonjs/core/Materials/Textures/texture.js';
import { RenderTargetTexture } from '@babylonjs/core/Materials/Textures/renderTargetTexture.js';
import { Constants } from '@babylonjs/core/Engines/constants.js';
import { LoadAssetContainerAsync } from '@babylonjs/core/Loading/sceneLoader.js';
import '@babylonjs/loaders/glTF/glTFFileLoader.js';
import '@babylonjs/loaders/glTF/2.0/index.js';
import { loadLutbakeRuntime, lutbakeIridescence } from './lutbake-babylon.js';
import { NAME, loadLutbakeBakeBabylon, registerLutbakeGltf } from './lutbake-babylon-gltf.js';
import { gltfCells, sphereCells, thicknessWeights } from './sphere-samples.js';
import { interleavedTimes } from './cost-rounds.js';

const engine = new Engine(document.getElementById('view'), false, { preserveDrawingBuffer: true });
const scene = new Scene(engine);
scene.clearColor = new Color4(0, 0, 0, 0);
const camera = new FreeCamera('camera', new Vector3(0, 0, -3), scene);
camera.setTarget(Vector3.Zero());
camera.mode = Camera.ORTHOGRAPHIC_CAMERA;
[camera.orthoLeft, camera.orthoRight, camera.orthoBottom, camera.orthoTop] = [-1.02, 1.02, -1.02, 1.02];
const sphere = CreateSphere('sphere', { diameter: 2, segments: 96 }, scene);

// Film thickness weights at random per texel, read by nearest filtering.
function thicknessTexture(seed) {
  return new RawTexture(thicknessWeights(seed), 64, 32, Constants.TEXTUREFORMAT_RGBA, scene, false, false,
    Texture.NEAREST_SAMPLINGMODE);
}

function pbrMaterial(m, k) {
  const material = new PBRMaterial(`m${k}`, scene);
  material.onError = (effect, errors) => {
    const line = Number((errors.match(/ERROR: 0:(\d+)/) || [])[1]);
    const code = effect.fragmentSourceCode.split('\n');
    console.error(`${material.name}: ${errors}\n${code.slice(Math.max(0, line - 4), line + 2).join('\n')}`);
  };
  material.metallic = m.metal ? 1 : 0;
  material.roughness = 0.3;
  material.indexOfRefraction = m.ior;
  if (m.metal) material.albedoColor = new Color3(...m.metal.f0);
  material.iridescence.isEnabled = true;
  material.iridescence.intensity = 1;
  material.iridescence.indexOfRefraction = m.iridescenceIOR;
  [material.iridescence.minimumThickness, material.iridescence.maximumThickness] = m.thickness;
  if (m.thickness[0] !== m.thickness[1]) material.iridescence.thicknessTexture = thicknessTexture(k + 1);
  return material;
}

async function render(material, size) {
  const target = new RenderTargetTexture('target', size, scene, {
    type: Constants.TEXTURETYPE_FLOAT, generateMipMaps: false, samplingMode: Texture.NEAREST_SAMPLINGMODE });
  target.renderList = [sphere];
  target.activeCamera = camera;
  target.clearColor = new Color4(0, 0, 0, 0);
  sphere.material = material;
  await scene.whenReadyAsync();
  const start = performance.now();
  await new Promise((ok, no) => {
    const wait = () => {
      if (material.isReady(sphere)) ok();
      else if (performance.now() - start > 60000) no(new Error(`material ${material.name} not ready after 60 s (shader errors above)`));
      else setTimeout(wait, 10);
    };
    wait();
  });
  target.render();
  const pixels = await target.readPixels();
  target.dispose();
  return new Float32Array(pixels.buffer);
}

window.lutbakeBabylon = async ({ runtime: stem, materials, modes, size = 96, stride = 2, image = false }) => {
  const runtime = await loadLutbakeRuntime(stem, scene);
  const cells = await sphereCells({ materials, modes, runtime, make: pbrMaterial, attach: lutbakeIridescence, render,
                                    size, stride, image });
  const gl = engine._gl;
  const { textureType, samplingMode, anisotropicFilteringLevel, wrapU, wrapV } = runtime.table;
  return { babylon: Engine.Version, webgl: engine.webGLVersion, renderer: gl.getParameter(gl.RENDERER),
           texture: { textureType, samplingMode, anisotropicFilteringLevel, wrapU, wrapV }, cells };
};
// --- cost: wall per draw of a sphere lit by one directional light filling a size² float target, per material: no iridescence,
// Babylon's own, lutbake's runtime table (engine/cost-rounds.js: interleaved rounds).
// The sphere drawn into `target` with each entry's material, timed by interleavedTimes.
function timing(target, rounds, draws) {
  const pixel = new Float32Array(4);
  return { rounds, draws, show: ({ material }) => { sphere.material = material; }, draw: () => target.render(),
           wait: () => target.readPixels(0, 0, pixel, true, false, 0, 0, 1, 1) };
}

// The size² float target the cost pages draw the sphere into.
function costTarget(size) {
  const target = new RenderTargetTexture('cost', size, scene, { type: Constants.TEXTURETYPE_FLOAT, generateMipMaps: false });
  target.renderList = [sphere];
  target.activeCamera = camera;
  return target;
}

// Each entry's material made ready on the sphere (its shader compiled).
async function compileAll(entries) {
  for (const { material } of entries) {
    sphere.material = material;
    await scene.whenReadyAsync();
    while (!material.isReady(sphere)) await new Promise((ok) => setTimeout(ok, 10));
  }
}

window.lutbakeBabylonCost = async ({ runtime: stem, materials, size = 256, rounds = 7, draws = 3 }) => {
  const runtime = await loadLutbakeRuntime(stem, scene);
  const light = new DirectionalLight('light', new Vector3(-0.3, -0.5, 1), scene);  // the term is lit: not dead code
  const entries = [];
  for (const [k, m] of materials.entries()) {
    for (const mode of ['none', 'babylon', 'runtime']) {
      const material = pbrMaterial(m, k);
      material.iridescence.isEnabled = mode !== 'none';
      if (mode === 'runtime') lutbakeIridescence(material, { runtime, metal: m.metal || undefined });
      entries.push({ name: `${m.label}|${mode}`, material });
    }
  }
  const target = costTarget(size);
  await compileAll(entries);
  const times = await interleavedTimes(entries, timing(target, rounds, draws));
  target.dispose();
  light.dispose();
  return { babylon: Engine.Version, size, times };
};

// A glTF asset loaded with lutbake's loader extension: each of its iridescent materials rendered on the
// sphere, its Fresnel term and parameters read back as above (the asset's own meshes are not drawn).
// With `manifest` (a `lutbake bake --gltf` output) the extension serves the bake's routes (`serve`: 'bake' or
// 'runtime'), each cell saying which (lutbake: {gltfIndex, name, parts}).
window.lutbakeBabylonGltf = async ({ runtime: stem, asset, metals, manifest = null, serve = 'bake', size = 96, stride = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, scene);
  const bake = manifest && await loadLutbakeBakeBabylon(manifest, scene);
  registerLutbakeGltf();
  const load = async (output) => {
    const extensionOptions = { [NAME]: { runtime, metals, output, bake, serve } };
    const container = await LoadAssetContainerAsync(asset, scene, { pluginOptions: { gltf: { extensionOptions } } });
    return container.materials.filter((m) => m.iridescence && m.iridescence.isEnabled);
  };
  const cells = await gltfCells(load, render, (m) => ({ name: m.name, ior: m.indexOfRefraction, metallic: m.metallic,
                                                        lutbake: (m.metadata && m.metadata.lutbake) || null }), size, stride);
  return { babylon: Engine.Version, cells };
};

// --- glTF cost: the glTF asset at `asset` loaded four ways: none (Babylon's loader, iridescence then turned off:
// the draw without a film term), stock (Babylon's own KHR_materials_iridescence, no lutbake extension), and with
// lutbake's loader extension serving the `lutbake bake --gltf` output at `manifest` by its routes (bake: atlas
// slices, 4D LUTs, texture-driven metals through their F0 table) or all on the runtime table (runtime); each
// iridescent material on the sphere, lit as in the cost above, timed in interleaved rounds; per entry
// (`gltfIndex|route`) the wall per draw, the routes lutbake served and the fragment shader Babylon compiled (its
// effect's source, as WebGL2 received it).
window.lutbakeBabylonGltfCost = async ({ runtime: stem, asset, manifest, size = 64, rounds = 3, draws = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, scene);
  const bake = await loadLutbakeBakeBabylon(manifest, scene);
  registerLutbakeGltf();
  const load = async (options) => {
    const pluginOptions = { gltf: { extensionOptions: options ? { [NAME]: options } : {} } };
    const container = await LoadAssetContainerAsync(asset, scene, { pluginOptions });
    return container.materials.filter((m) => m.iridescence && m.iridescence.isEnabled);
  };
  const loads = { none: await load(null), stock: await load(null), bake: await load({ runtime, bake, serve: 'bake' }),
                  runtime: await load({ runtime, bake, serve: 'runtime' }) };
  for (const material of loads.none) material.iridescence.isEnabled = false;
  const entries = [];
  for (const [k, served] of loads.bake.entries()) {
    for (const [route, materials] of Object.entries(loads)) {
      entries.push({ name: `${served.metadata.lutbake.gltfIndex}|${route}`, material: materials[k],
                     parts: (materials[k].metadata && materials[k].metadata.lutbake || {}).parts || null });
    }
  }
  const light = new DirectionalLight('light', new Vector3(-0.3, -0.5, 1), scene);
  const target = costTarget(size);
  await compileAll(entries);
  const shaders = {};
  for (const { name, material } of entries) {
    sphere.material = material;
    target.render();
    shaders[name] = material.getEffect().fragmentSourceCode;  // the effect the last draw bound
  }
  const times = await interleavedTimes(entries, timing(target, rounds, draws));
  target.dispose();
  light.dispose();
  return { babylon: Engine.Version, size, times, shaders, routes: Object.fromEntries(entries.map((e) => [e.name, e.parts])) };
};
window.lutbakeReady = true;
