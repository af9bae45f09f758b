// The engine side of tests/engines/test_gltf_engine.py and tests/engines/test_gltf_runtime.py: three.js's GLTFLoader loads a
// glTF asset with lutbake's plugin (engine/lutbake-gltf.js) and renders each mesh alone into a float target:
// the film term the material computes (material.iridescenceFresnel), the parameters it used (cos theta,
// thickness, metalness, iridescence) and its base colour, then the film term again for each further way of
// serving the materials (`serves`: 'bake', 'runtime'). The tests recompute the term from those parameters.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { loadLutbakeBake, loadLutbakePlan, LutbakeGLTFPlugin } from './lutbake-gltf.js';
import { loadLutbakeRuntime } from './lutbake-iridescence.js';

const renderer = new THREE.WebGLRenderer({ antialias: false });
document.body.appendChild(renderer.domElement);
const shaderErrors = [];
renderer.debug.onShaderError = (gl, program, vertex, fragment) => {
  shaderErrors.push(`${gl.getShaderInfoLog(vertex)}\n${gl.getShaderInfoLog(fragment)}`);
};

// Each mesh alone, orthographic from +z, size² pixels of RGBA float.
function renderMesh(mesh, size) {
  const target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType, depthBuffer: true });
  const scene = new THREE.Scene();
  scene.add(mesh);
  const camera = new THREE.OrthographicCamera(-1.02, 1.02, 1.02, -1.02, 0.1, 10);
  camera.position.set(0, 0, 3);
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, camera);
  renderer.setRenderTarget(null);
  if (shaderErrors.length) throw new Error(`shader does not compile: ${shaderErrors.join('\n')}`);
  const pixels = new Float32Array(size * size * 4);
  renderer.readRenderTargetPixels(target, 0, 0, size, size, pixels);
  target.dispose();
  return pixels;
}

// {glTF material index: pixels} of every mesh whose material the plugin patched, under `options` (the
// plugin's), what served each material (plugin.served), and how many programs they need (distinct keys).
async function renders(gltfUrl, bake, options, size) {
  let plugin = null;
  const loader = new GLTFLoader().register((parser) => (plugin = new LutbakeGLTFPlugin(parser, bake, options)));
  const gltf = await loader.loadAsync(gltfUrl);
  const meshes = [];
  gltf.scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
  const pixels = {}, keys = new Set();
  for (const mesh of meshes) {
    const index = gltf.parser.associations.get(mesh.material).materials;
    const key = mesh.material.customProgramCacheKey();
    if (key.startsWith('lutbake-gltf:')) {
      pixels[index] = renderMesh(mesh, size);
      keys.add(key);
    }
  }
  return { pixels, served: Object.fromEntries(plugin.served), programs: keys.size };
}

// Per material, at every `stride`-th covered pixel: [film term (3), cos theta, thickness, metalness,
// iridescence, base colour (3), then the film term of each further serve (3 each)]. `manifest` (a bake) or
// `plan` (`lutbake plan --gltf --json`: no bake) gives the mapping; `runtime` the runtime table's stem.
async function run({ gltf, manifest = null, plan = null, runtime = null, serves = ['bake'], size = 96, stride = 3 }) {
  const bake = manifest ? await loadLutbakeBake(manifest) : await loadLutbakePlan(plan);
  const table = runtime ? await loadLutbakeRuntime(runtime, { renderer }) : null;   // float32: this context filters it
  const passes = [['fresnel', serves[0]], ['parameters', serves[0]], ['basecolor', serves[0]],
                  ...serves.slice(1).map((serve) => ['fresnel', serve])];
  const rendered = await Promise.all(passes.map(([output, serve]) => renders(gltf, bake, { output, serve, runtime: table }, size)));
  const [fresnel, params, colour, ...others] = rendered.map((r) => r.pixels);
  const materials = {};
  for (const index of Object.keys(fresnel)) {
    const samples = [];
    for (let k = 0; k < size * size; k += stride) {
      const p = 4 * k;
      if (fresnel[index][p + 3] === 0 || params[index][p + 3] <= 0) continue;  // background, or no film there
      samples.push([...fresnel[index].subarray(p, p + 3), ...params[index].subarray(p, p + 4), ...colour[index].subarray(p, p + 3),
                    ...others.flatMap((o) => [...o[index].subarray(p, p + 3)])]);
    }
    materials[index] = samples;
  }
  const first = (i) => rendered[i === 0 ? 0 : i + 2];   // each serve's fresnel pass
  const served = Object.fromEntries(serves.map((serve, i) => [serve, first(i).served]));
  const programs = Object.fromEntries(serves.map((serve, i) => [serve, first(i).programs]));
  return { materials, served, programs };
}

// Every mesh of a sphere-grid asset in one scene, `columns` to a row, one unit sphere per cell of `cell`
// pixels, drawn in one frame by `renderer` into a float target: the frame's wall time from render() to the
// pixels read back (the first frame: programs compiled, textures uploaded), and per glTF material its pixels.
async function gridFrame(renderer, gltfUrl, register, columns, cell) {
  const loader = new GLTFLoader();
  let plugin = null;
  if (register) loader.register((parser) => (plugin = register(parser)));
  const gltf = await loader.loadAsync(gltfUrl);
  const meshes = [];
  gltf.scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
  const rows = Math.ceil(meshes.length / columns), scene = new THREE.Scene();
  meshes.forEach((mesh, k) => { mesh.position.set(2.1 * (k % columns), -2.1 * Math.floor(k / columns), 0); scene.add(mesh); });
  const light = new THREE.DirectionalLight(0xffffff, 2.0);
  light.position.set(1, 1, 3);
  scene.add(light);
  const camera = new THREE.OrthographicCamera(-1.05, 2.1 * columns - 1.05, 1.05, 1.05 - 2.1 * rows, 0.1, 10);
  camera.position.set(0, 0, 3);
  const [width, height] = [columns * cell, rows * cell];
  const target = new THREE.WebGLRenderTarget(width, height, { type: THREE.FloatType, depthBuffer: true });
  const pixels = new Float32Array(width * height * 4);
  const start = performance.now();
  renderer.setRenderTarget(target);
  renderer.setClearColor(0x000000, 0);
  renderer.clear();
  renderer.render(scene, camera);
  renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
  const ms = performance.now() - start;
  renderer.setRenderTarget(null);
  target.dispose();
  if (shaderErrors.length) throw new Error(`shader does not compile: ${shaderErrors.join('\n')}`);
  const byMaterial = {};
  meshes.forEach((mesh, k) => {
    const index = gltf.parser.associations.get(mesh.material).materials;
    const [x0, y0] = [(k % columns) * cell, height - (Math.floor(k / columns) + 1) * cell];
    const own = new Float32Array(cell * cell * 4);
    for (let y = 0; y < cell; y++) own.set(pixels.subarray(4 * ((y0 + y) * width + x0), 4 * ((y0 + y) * width + x0 + cell)), 4 * y * cell);
    byMaterial[index] = own;
  });
  return { ms, pixels: byMaterial, served: plugin ? Object.fromEntries(plugin.served) : {},
           keys: new Set(meshes.map((m) => m.material.customProgramCacheKey())).size };
}

// The sphere grid of tests/engines/test_gltf_engine.py and bench/bench_gltf_runtime.py, for each serve in
// `serves` ('three': stock three.js's own iridescence, no plugin; 'bake', 'runtime': lutbake's plugin) on a
// fresh renderer: the lit first frame's wall time and renderer.info.programs.length after it, and with
// `samples` the film term and parameters at every `stride`-th covered pixel (as `run` returns them). The
// runtime table is uploaded as `precision` says ('float', 'half', or null: the context's choice).
window.lutbakeGltfGrid = async ({ gltf, manifest = null, plan = null, runtime = null, precision = null, serves,
                                   columns = 7, cell = 20, stride = 1, samples = true }) => {
  const bake = manifest ? await loadLutbakeBake(manifest) : plan ? await loadLutbakePlan(plan) : null;
  const out = {};
  for (const serve of serves) {
    const grid = new THREE.WebGLRenderer({ antialias: false });
    grid.debug.onShaderError = renderer.debug.onShaderError;
    const table = runtime ? await loadLutbakeRuntime(runtime, { renderer: grid, precision }) : null;
    const register = (output) => (serve === 'three' ? null
      : (parser) => new LutbakeGLTFPlugin(parser, bake, { output, serve, runtime: table }));
    const lit = await gridFrame(grid, gltf, register(null), columns, cell);
    const result = { first_frame_ms: lit.ms, programs: grid.info.programs.length, keys: lit.keys, served: lit.served,
                     precision: table ? table.precision : null };
    if (samples && serve !== 'three') {
      const passes = [];
      for (const output of ['fresnel', 'parameters', 'basecolor']) passes.push((await gridFrame(grid, gltf, register(output), columns, cell)).pixels);
      const [fresnel, params, colour] = passes;
      result.materials = Object.fromEntries(Object.keys(fresnel).map((index) => {
        const rows = [];
        for (let k = 0; k < cell * cell; k += stride) {
          const p = 4 * k;
          if (fresnel[index][p + 3] === 0 || params[index][p + 3] <= 0) continue;  // background, or no film there
          rows.push([...fresnel[index].subarray(p, p + 3), ...params[index].subarray(p, p + 4), ...colour[index].subarray(p, p + 3)]);
        }
        return [index, rows];
      }));
    }
    grid.dispose();
    grid.forceContextLoss();
    out[serve] = result;
  }
  const gl = renderer.getContext();
  return { renderer: gl.getParameter(gl.RENDERER), three: THREE.REVISION, ...out };
};

// `specs`: one {gltf, manifest} per asset (URLs); one result per spec, {glTF material index: samples}.
// `served`: per spec, {serve: {glTF material index: {gltfIndex, name, parts: {part: route}}}}; `programs`: per
// spec, {serve: the distinct program cache keys among the patched materials}.
window.lutbakeGltf = async (specs) => {
  const runs = [];
  for (const spec of specs) runs.push(await run(spec));
  const gl = renderer.getContext();
  return { renderer: gl.getParameter(gl.RENDERER), three: THREE.REVISION, results: runs.map((r) => r.materials),
           served: runs.map((r) => r.served), programs: runs.map((r) => r.programs) };
};
window.lutbakeReady = true;
