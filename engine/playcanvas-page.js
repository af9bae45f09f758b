// PlayCanvas's StandardMaterial with lutbake's runtime table in headless Chromium (engine/harness.mjs
// playcanvas, tests/engines/test_playcanvas_engine.py): per material, a sphere rendered into a float target
// with the film's Fresnel term as output and again with the parameters each pixel used, for PlayCanvas's own
// term and lutbake's.
import * as pc from 'playcanvas';
import { loadLutbakeBakePlaycanvas, loadLutbakeRuntime, lutbakeGltfOptions, lutbakeIridescence } from './lutbake-playcanvas.js';
import { gltfCells, sphereCells } from './sphere-samples.js';

const app = new pc.Application(document.getElementById('view'), { graphicsDeviceOptions: { deviceTypes: ['webgl2'] } });
const device = app.graphicsDevice;
app.start();
const camera = new pc.Entity('camera');
camera.addComponent('camera', { projection: pc.PROJECTION_ORTHOGRAPHIC, orthoHeight: 1.02, clearColor: new pc.Color(0, 0, 0, 0),
                                nearClip: 0.1, farClip: 10, toneMapping: pc.TONEMAP_LINEAR, gammaCorrection: pc.GAMMA_NONE });
camera.setPosition(0, 0, 3);
app.root.addChild(camera);
const sphere = new pc.Entity('sphere');
sphere.addComponent('render', { type: 'sphere' });
sphere.setLocalScale(2, 2, 2);
app.root.addChild(sphere);

// One film thickness per material (its maximum): no iridescenceThicknessMap here (lutbake-playcanvas.js
// fixIridescenceThicknessMap makes one compile; the glTF page reads one), so the films vary by material.
function standardMaterial(m) {
  const material = new pc.StandardMaterial();
  material.useMetalness = true;
  material.metalness = m.metal ? 1 : 0;
  material.gloss = 0.7;
  material.refractionIndex = 1 / m.ior;
  if (m.metal) material.diffuse = new pc.Color(...m.metal.f0);
  material.useIridescence = true;
  material.iridescence = 1;
  material.iridescenceRefractionIndex = m.iridescenceIOR;
  [material.iridescenceThicknessMin, material.iridescenceThicknessMax] = m.thickness;
  return material;
}

async function render(material, size) {
  const colour = new pc.Texture(device, { width: size, height: size, format: pc.PIXELFORMAT_RGBA32F, mipmaps: false,
                                          minFilter: pc.FILTER_NEAREST, magFilter: pc.FILTER_NEAREST });
  const target = new pc.RenderTarget({ colorBuffer: colour, depth: true });
  camera.camera.renderTarget = target;
  sphere.render.material = material;
  for (let frame = 0; frame < 2; frame++) await new Promise((ok) => app.once('frameend', ok));
  const pixels = await colour.read(0, 0, size, size, { renderTarget: target, immediate: true });
  camera.camera.renderTarget = null;
  target.destroy();
  colour.destroy();
  return pixels;
}

window.lutbakePlaycanvas = async ({ runtime: stem, materials, modes, size = 96, stride = 2, image = false }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const attach = (material, options) => lutbakeIridescence(material, { ...options, device });
  const cells = await sphereCells({ materials, modes, runtime, make: standardMaterial, attach, render, size, stride, image });
  const { format, mipmaps, anisotropy, minFilter, magFilter, addressU, addressV } = runtime.table;
  return { playcanvas: pc.version, device: device.deviceType, renderer: device.unmaskedRenderer ?? '',
           texture: { format, mipmaps, anisotropy, minFilter, magFilter, addressU, addressV }, cells };
};
// --- cost: wall per draw of a sphere lit by one directional light filling a size² float target, per
// material: no iridescence, PlayCanvas's own, lutbake's runtime table; interleaved rounds (the order
// rotates), each waits for the GPU (a one-pixel read); round 0 (compilation) is dropped.
window.lutbakePlaycanvasCost = async ({ runtime: stem, materials, size = 256, rounds = 7, draws = 3 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const light = new pc.Entity('light');
  light.addComponent('light', { type: 'directional' });
  light.setEulerAngles(30, 20, 0);
  app.root.addChild(light);
  const entries = [];
  for (const m of materials) {
    for (const mode of ['none', 'playcanvas', 'runtime']) {
      const material = standardMaterial(m);
      material.useIridescence = mode !== 'none';
      if (mode === 'runtime') lutbakeIridescence(material, { runtime, metal: m.metal || undefined });
      material.update();
      entries.push({ name: `${m.label}|${mode}`, material });
    }
  }
  const colour = new pc.Texture(device, { width: size, height: size, format: pc.PIXELFORMAT_RGBA32F, mipmaps: false });
  const target = new pc.RenderTarget({ colorBuffer: colour, depth: true });
  camera.camera.renderTarget = target;
  app.autoRender = false;
  const times = Object.fromEntries(entries.map((e) => [e.name, []]));
  const wait = () => colour.read(0, 0, 1, 1, { renderTarget: target, immediate: true });
  for (let round = 0; round <= rounds; round++) {
    for (let i = 0; i < entries.length; i++) {
      const { name, material } = entries[(i + round) % entries.length];
      sphere.render.material = material;
      await wait();
      const start = performance.now();
      for (let d = 0; d < draws; d++) app.render();
      await wait();
      if (round > 0) times[name].push((performance.now() - start) / draws);
    }
  }
  app.autoRender = true;
  camera.camera.renderTarget = null;
  light.destroy();
  target.destroy();
  colour.destroy();
  return { playcanvas: pc.version, size, times };
};
// A glTF asset loaded as a container with lutbake's material hook: each of its iridescent materials rendered
// on the sphere, its Fresnel term and parameters read back as above (the asset itself is not instantiated).
// With `manifest` (a `lutbake bake --gltf` output) the hook serves the bake's routes (`serve`: 'bake' or
// 'runtime'), each cell saying which (lutbake: {gltfIndex, name, parts}).
window.lutbakePlaycanvasGltf = async ({ runtime: stem, asset: url, metals, manifest = null, serve = 'bake', size = 96, stride = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const bake = manifest && await loadLutbakeBakePlaycanvas(manifest, device);
  // PlayCanvas caches a container by URL: the query keeps the two loads (and their hooks) apart.
  const load = (output) => new Promise((ok, no) => {
    const asset = new pc.Asset(`films-${output}`, 'container', { url: `${url}?output=${output}&serve=${serve}` }, null,
                               lutbakeGltfOptions({ runtime, metals, output, bake, serve }));
    asset.once('error', no);
    asset.ready(() => ok(asset.resource.data.materials.filter((m) => m.useIridescence)));
    app.assets.add(asset);
    app.assets.load(asset);
  });
  const cells = await gltfCells(load, render, (m) => ({ name: m.name, ior: 1 / m.refractionIndex, metallic: m.metalness,
                                                        lutbake: m.lutbake || null }), size, stride);
  return { playcanvas: pc.version, cells };
};
window.lutbakeReady = true;
