// The engine side of tests/test_gltf_engine.py: three.js's GLTFLoader loads a glTF asset with lutbake's
// plugin (engine/lutbake-gltf.js) and renders each mesh alone into a float target, three times: the film
// term the material computes (material.iridescenceFresnel), the parameters it used (cos theta, thickness,
// metalness, iridescence) and its base colour. The test recomputes the term with `lutbake sample`'s
// sampler from those parameters.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { loadLutbakeBake, LutbakeGLTFPlugin } from './lutbake-gltf.js';

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

// {glTF material index: pixels} of every mesh whose material the plugin patched, under `output`.
async function renders(gltfUrl, bake, output, size) {
  const loader = new GLTFLoader().register((parser) => new LutbakeGLTFPlugin(parser, bake, { output }));
  const gltf = await loader.loadAsync(gltfUrl);
  const meshes = [];
  gltf.scene.traverse((o) => { if (o.isMesh) meshes.push(o); });
  const out = {};
  for (const mesh of meshes) {
    const index = gltf.parser.associations.get(mesh.material).materials;
    if (mesh.material.customProgramCacheKey().startsWith('lutbake-gltf:')) out[index] = renderMesh(mesh, size);
  }
  return out;
}

async function run({ gltf, manifest, size = 96, stride = 3 }) {
  const bake = await loadLutbakeBake(manifest);
  const [fresnel, params, colour] = await Promise.all(['fresnel', 'parameters', 'basecolor']
    .map((output) => renders(gltf, bake, output, size)));
  const materials = {};
  for (const index of Object.keys(fresnel)) {
    const samples = [];
    for (let k = 0; k < size * size; k += stride) {
      const p = 4 * k;
      if (fresnel[index][p + 3] === 0 || params[index][p + 3] <= 0) continue;  // background, or no film there
      samples.push([...fresnel[index].subarray(p, p + 3), ...params[index].subarray(p, p + 4), ...colour[index].subarray(p, p + 3)]);
    }
    materials[index] = samples;
  }
  return materials;
}

// `specs`: one {gltf, manifest} per asset (URLs); one result per spec, {glTF material index: samples}.
window.lutbakeGltf = async (specs) => {
  const out = [];
  for (const spec of specs) out.push(await run(spec));
  const gl = renderer.getContext();
  return { renderer: gl.getParameter(gl.RENDERER), three: THREE.REVISION, results: out };
};
window.lutbakeReady = true;
