// three.js's WebGPURenderer (WebGPU backend only, no WebGL2 fallback) with lutbake's TSL node in
// MeshPhysicalNodeMaterial, in headless Chromium (engine/harness.mjs webgpu, tests/engines/test_webgpu_engine.py):
// per material, a lit sphere rendered into a float target with the film's Fresnel term as output and again
// with the parameters each pixel used, for three.js's own term and lutbake's.
import * as THREE from 'three/webgpu';
import { loadLutbakeRuntimeNode, lutbakeNodeIridescence } from './lutbake-tsl.js';
import { coveredSamples, sphereCells, thicknessWeights } from './sphere-samples.js';

const renderer = new THREE.WebGPURenderer({ canvas: document.getElementById('view'), antialias: false });
renderer.toneMapping = THREE.NoToneMapping;
renderer.outputColorSpace = THREE.LinearSRGBColorSpace;
const scene = new THREE.Scene();
const camera = new THREE.OrthographicCamera(-1.02, 1.02, 1.02, -1.02, 0.1, 20);
camera.position.set(0, 0, 3);
const light = new THREE.DirectionalLight(0xffffff, 2);  // the lighting model runs only where a light is
light.position.set(-0.3, 0.5, 1);
scene.add(light);
const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, 96, 64));
scene.add(sphere);

// Film thickness weights at random per texel, read by nearest filtering.
function thicknessTexture(seed) {
  const texture = new THREE.DataTexture(thicknessWeights(seed), 64, 32);
  texture.magFilter = texture.minFilter = THREE.NearestFilter;
  texture.needsUpdate = true;
  return texture;
}

function physicalMaterial(m, k) {
  const material = new THREE.MeshPhysicalNodeMaterial({ roughness: 0.3, metalness: m.metal ? 1 : 0, ior: m.ior });
  if (m.metal) material.color.setRGB(...m.metal.f0, THREE.LinearSRGBColorSpace);
  material.iridescence = 1;
  material.iridescenceIOR = m.iridescenceIOR;
  [material.iridescenceThicknessMinimum, material.iridescenceThicknessMaximum] = m.thickness;
  if (m.thickness[0] !== m.thickness[1]) material.iridescenceThicknessMap = thicknessTexture(k + 1);
  return material;
}

async function render(material, size) {
  const target = new THREE.RenderTarget(size, size, { type: THREE.FloatType, depthBuffer: true });
  sphere.material = material;
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, camera);
  const pixels = await renderer.readRenderTargetPixelsAsync(target, 0, 0, size, size);
  renderer.setRenderTarget(null);
  target.dispose();
  return new Float32Array(pixels.buffer, pixels.byteOffset, size * size * 4);
}

async function webgpu() {
  await renderer.init();
  if (!renderer.backend.isWebGPUBackend) throw new Error('WebGPURenderer fell back to WebGL2: no WebGPU adapter');
  const adapter = await navigator.gpu.requestAdapter();
  return adapter.info ? `${adapter.info.vendor} / ${adapter.info.architecture}` : 'unknown';
}

// `stretch` (the tests' 3): the sphere stretched along the view, so its pixels' cos theta =
// sqrt(1 - r^2) / sqrt(9 r^2 + 1 - r^2) reach below 0.05 within the pixels a 64^2 render covers (a round
// sphere's outermost pixels stop near 0.1): the sweep passes through the grazing angles some searched worst
// points sit at, and still densely through cos 1.
window.lutbakeWebgpu = async ({ runtime: stem, materials, modes, size = 96, stride = 2, image = false, stretch = 3 }) => {
  const adapter = await webgpu();
  sphere.scale.z = stretch;
  camera.position.z = 2 + stretch;  // in front of the stretched sphere
  const runtime = await loadLutbakeRuntimeNode(stem);
  const cells = await sphereCells({ materials, modes, runtime, make: physicalMaterial, attach: lutbakeNodeIridescence,
                                    render, size, stride, image });
  const litCells = [];
  for (const [k, m] of materials.entries()) {
    // The lit colour (no output) with each term and with none: the term must reach the lighting.
    const none = physicalMaterial(m, k);
    none.iridescence = 0;
    const lit = { none: await render(none, size) };
    for (const mode of modes) lit[mode] = await render(lutbakeNodeIridescence(physicalMaterial(m, k), { runtime, mode, metal: m.metal || undefined }), size);
    litCells.push(Object.fromEntries(Object.entries(lit).map(([mode, pixels]) => [mode, coveredSamples(pixels, pixels, size, stride).map((row) => row.slice(0, 3))])));
  }
  const { type, magFilter, minFilter, generateMipmaps, wrapS, wrapT, anisotropy } = runtime.table;
  return { three: THREE.REVISION, backend: 'webgpu', adapter,
           texture: { type, magFilter, minFilter, generateMipmaps, wrapS, wrapT, anisotropy }, cells, lit: litCells };
};

// --- cost: wall per draw of the lit sphere filling a size² float target, per material: no iridescence,
// three.js's own, lutbake's runtime node; interleaved rounds (the order rotates), each waits for the GPU
// (a one-pixel read), so a slow stretch of a shared machine hits every entry alike; round 0 is dropped.
// With `wgsl`, the fragment shader of each entry comes back too (its WGSL, as three.js generated it).
window.lutbakeWebgpuCost = async ({ runtime: stem, materials, size = 256, rounds = 7, draws = 3 }) => {
  await webgpu();
  const runtime = await loadLutbakeRuntimeNode(stem);
  const entries = [];
  for (const [k, m] of materials.entries()) {
    for (const mode of ['none', 'three', 'runtime']) {
      const material = physicalMaterial(m, k);
      material.iridescence = mode === 'none' ? 0 : 1;
      if (mode === 'runtime') lutbakeNodeIridescence(material, { runtime, metal: m.metal || undefined });
      entries.push({ name: `${m.label}|${mode}`, material });
    }
  }
  const target = new THREE.RenderTarget(size, size, { type: THREE.FloatType });
  renderer.setRenderTarget(target);
  const wait = () => renderer.readRenderTargetPixelsAsync(target, 0, 0, 1, 1);
  // The WGSL each entry's pipeline was made from, as the device received it (renderer.debug.getShaderAsync
  // builds without the scene's lights).
  const device = renderer.backend.device;
  const modules = [];
  const createShaderModule = device.createShaderModule.bind(device);
  device.createShaderModule = (descriptor) => { modules.push(descriptor.code); return createShaderModule(descriptor); };
  const shaders = {};
  for (const { name, material } of entries) {
    const first = modules.length;
    sphere.material = material;
    renderer.render(scene, camera);
    await wait();
    // Materials of one program share its module: the first entry of a mode made it.
    const mode = name.split('|')[1];
    shaders[name] = modules.slice(first).find((code) => code.includes('@fragment'))
      || Object.entries(shaders).find(([other]) => other.endsWith(`|${mode}`))[1];
  }
  device.createShaderModule = createShaderModule;
  const times = Object.fromEntries(entries.map((e) => [e.name, []]));
  for (let round = 0; round <= rounds; round++) {
    for (let i = 0; i < entries.length; i++) {
      const { name, material } = entries[(i + round) % entries.length];
      sphere.material = material;
      await wait();
      const start = performance.now();
      for (let d = 0; d < draws; d++) renderer.render(scene, camera);
      await wait();
      if (round > 0) times[name].push((performance.now() - start) / draws);
    }
  }
  renderer.setRenderTarget(null);
  target.dispose();
  return { three: THREE.REVISION, size, times, shaders };
};
window.lutbakeReady = true;
