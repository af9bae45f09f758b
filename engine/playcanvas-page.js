// PlayCanvas's StandardMaterial with lutbake's runtime table in headless Chromium (engine/harness.mjs
// playcanvas, tests/engines/test_playcanvas_engine.py): per material, a sphere rendered into a float target
// with the film's Fresnel term as output and again with the parameters each pixel used, for PlayCanvas's own
// term and lutbake's.
import * as pc from 'playcanvas';
import { fixIridescenceThicknessMap, loadLutbakeBakePlaycanvas, loadLutbakeRuntime, lutbakeGltfOptions,
         lutbakeIridescence } from './lutbake-playcanvas.js';
import { gltfCells, sphereCells, thicknessWeights } from './sphere-samples.js';
import { interleavedTimes } from './cost-rounds.js';

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

// Film thickness weights at random per texel (the glTF thickness texture's G), read by nearest filtering, as
// Babylon's page reads them.
function thicknessTexture(seed) {
  return new pc.Texture(device, {
    name: `thickness-${seed}`, width: 64, height: 32, format: pc.PIXELFORMAT_RGBA8, mipmaps: false,
    minFilter: pc.FILTER_NEAREST, magFilter: pc.FILTER_NEAREST,
    addressU: pc.ADDRESS_CLAMP_TO_EDGE, addressV: pc.ADDRESS_CLAMP_TO_EDGE, levels: [thicknessWeights(seed)],
  });
}

// A film whose thickness range is not one value reads it from a random thickness map, with lutbake's fix of
// PlayCanvas's thickness map (lutbake-playcanvas.js: stock PlayCanvas 2.23.3 does not compile one), so
// PlayCanvas's own term (the mode without lutbake) compiles with it too.
function standardMaterial(m, k) {
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
  if (m.thickness[0] !== m.thickness[1]) {
    material.iridescenceThicknessMap = thicknessTexture(k + 1);
    fixIridescenceThicknessMap(material, device);
  }
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
// material: no iridescence, PlayCanvas's own, lutbake's runtime table (engine/cost-rounds.js: interleaved rounds).
window.lutbakePlaycanvasCost = async ({ runtime: stem, materials, size = 256, rounds = 7, draws = 3 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const entries = [];
  for (const [k, m] of materials.entries()) {
    for (const mode of ['none', 'playcanvas', 'runtime']) {
      const material = standardMaterial(m, k);
      material.useIridescence = mode !== 'none';
      if (mode === 'runtime') lutbakeIridescence(material, { runtime, metal: m.metal || undefined });
      material.update();
      entries.push({ name: `${m.label}|${mode}`, material });
    }
  }
  return withCostTarget(size, async (wait) => ({ playcanvas: pc.version, size,
    times: await interleavedTimes(entries, timing(wait, rounds, draws)) }));
};

// `run(wait)` with a directional light and the camera drawing into a size² float target on demand (autoRender
// off); `wait` reads one pixel of it (the GPU is done). Everything is put back after.
async function withCostTarget(size, run) {
  const light = new pc.Entity('light');
  light.addComponent('light', { type: 'directional' });
  light.setEulerAngles(30, 20, 0);
  app.root.addChild(light);
  const colour = new pc.Texture(device, { width: size, height: size, format: pc.PIXELFORMAT_RGBA32F, mipmaps: false });
  const target = new pc.RenderTarget({ colorBuffer: colour, depth: true });
  camera.camera.renderTarget = target;
  app.autoRender = false;
  try {
    return await run(() => colour.read(0, 0, 1, 1, { renderTarget: target, immediate: true }));
  } finally {
    app.autoRender = true;
    camera.camera.renderTarget = null;
    light.destroy();
    target.destroy();
    colour.destroy();
  }
}

// The sphere drawn with each entry's material, timed by interleavedTimes.
function timing(wait, rounds, draws) {
  return { rounds, draws, wait, show: ({ material }) => { sphere.render.material = material; }, draw: () => app.render() };
}

// A glTF asset loaded as a container with lutbake's material hook: each of its iridescent materials rendered
// on the sphere, its Fresnel term and parameters read back as above (the asset itself is not instantiated).
// With `manifest` (a `lutbake bake --gltf` output) the hook serves the bake's routes (`serve`: 'bake' or
// 'runtime'), each cell saying which (lutbake: {gltfIndex, name, parts}).
window.lutbakePlaycanvasGltf = async ({ runtime: stem, asset: url, metals, manifest = null, serve = 'bake', size = 96, stride = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const bake = manifest && await loadLutbakeBakePlaycanvas(manifest, device);
  const load = (output) => loadContainer(url, `output=${output}&serve=${serve}`,
                                       lutbakeGltfOptions({ runtime, metals, output, bake, serve }));
  const cells = await gltfCells(load, render, (m) => ({ name: m.name, ior: 1 / m.refractionIndex, metallic: m.metalness,
                                                        lutbake: m.lutbake || null }), size, stride);
  return { playcanvas: pc.version, cells };
};

// The glTF container at `url` loaded with `options` (container asset options: lutbakeGltfOptions, STOCK_OPTIONS);
// PlayCanvas caches a container by URL: `query` keeps loads (and their hooks) apart. Its iridescent materials.
function loadContainer(url, query, options) {
  return new Promise((ok, no) => {
    const asset = new pc.Asset(`films-${query}`, 'container', { url: `${url}?${query}` }, null, options);
    asset.once('error', no);
    asset.ready(() => ok(asset.resource.data.materials.filter((m) => m.useIridescence)));
    app.assets.add(asset);
    app.assets.load(asset);
  });
}

// PlayCanvas's own loader with the thickness map's fix alone (lutbake-playcanvas.js: PlayCanvas 2.23.3 does not
// compile a material with iridescenceThicknessMap), on every KHR_materials_iridescence material.
const STOCK_OPTIONS = {
  material: {
    postprocess(gltfMaterial, material) {
      if (gltfMaterial.extensions?.KHR_materials_iridescence) fixIridescenceThicknessMap(material, device);
    },
  },
};

// --- glTF cost: the glTF asset at `asset` loaded four ways: none (PlayCanvas's loader, iridescence then turned
// off: the draw without a film term), stock (PlayCanvas's own KHR_materials_iridescence with lutbake's fix of its
// thickness map alone, so its films follow their thickness textures as lutbake's do), and
// with lutbakeGltfOptions serving the `lutbake bake --gltf` output at `manifest` by its routes (bake: atlas slices,
// 4D LUTs, texture-driven metals through their F0 table) or all on the runtime table (runtime); each iridescent
// material on the sphere, lit as in the cost above, timed in interleaved rounds; per entry (`gltfIndex|route`) the
// wall per draw, the routes lutbake served and the fragment shader PlayCanvas compiled (the forward pass's shader
// as WebGL2 received it, else its definition's).
window.lutbakePlaycanvasGltfCost = async ({ runtime: stem, asset: url, manifest, size = 64, rounds = 3, draws = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const bake = await loadLutbakeBakePlaycanvas(manifest, device);
  const loads = { none: await loadContainer(url, 'cost=none', STOCK_OPTIONS),
                  stock: await loadContainer(url, 'cost=stock', STOCK_OPTIONS),
                  bake: await loadContainer(url, 'cost=bake', lutbakeGltfOptions({ runtime, bake, serve: 'bake' })),
                  runtime: await loadContainer(url, 'cost=runtime', lutbakeGltfOptions({ runtime, bake, serve: 'runtime' })) };
  for (const material of loads.none) {
    material.useIridescence = false;
    material.update();
  }
  const entries = [];
  for (const [k, served] of loads.bake.entries()) {
    for (const [route, materials] of Object.entries(loads)) {
      entries.push({ name: `${served.lutbake.gltfIndex}|${route}`, material: materials[k],
                     parts: (materials[k].lutbake || {}).parts || null });
    }
  }
  return withCostTarget(size, async (wait) => {
    const shaders = {};
    for (const { name, material } of entries) {
      sphere.render.material = material;
      app.render();
      await wait();
      const forward = [...sphere.render.meshInstances[0]._shaderCache.values()].find((s) => s.hashes[0] === pc.SHADER_FORWARD);
      // PlayCanvas's private fields (2.23.3): a version that moves them fails here, by name, not further on
      if (!forward?.shader) throw new Error(`PlayCanvas ${pc.version}: no forward-pass shader on the mesh instance to count`);
      shaders[name] = forward.shader.impl._fsource || forward.shader.definition.fshader;
    }
    const times = await interleavedTimes(entries, timing(wait, rounds, draws));
    return { playcanvas: pc.version, size, times, shaders, routes: Object.fromEntries(entries.map((e) => [e.name, e.parts])) };
  });
};
window.lutbakeReady = true;
