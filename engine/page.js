// The engine side of tests/engines/test_engine.py and of the viewer: three.js loads lutbake's files with its
// default loader settings and evaluates the shipped includes, unmodified, in a fragment shader.
import * as THREE from 'three';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';

// --- docs/engines.md snippet: begin
// A ShaderMaterial that calls a lutbake include. `textures` maps uniform names to textures loaded with
// `new EXRLoader().loadAsync(url)` (default settings); `includes` are the .glsl files' texts, pasted as
// they are; `body` is the fragment shader's main() using them.
function lutbakeMaterial({ textures, includes, body, vertexShader, uniforms = {} }) {
  const samplers = Object.keys(textures).map((name) => `uniform highp sampler2D ${name};`).join('\n');
  for (const [name, texture] of Object.entries(textures)) uniforms[name] = { value: texture };
  return new THREE.ShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms,
    vertexShader,
    fragmentShader: [samplers, ...includes, body].join('\n'),
  });
}
// --- docs/engines.md snippet: end

const FULLSCREEN_VS = 'void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }';
const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
document.body.appendChild(renderer.domElement);
const shaderErrors = [];
renderer.debug.onShaderError = (gl, program, vertex, fragment) => {
  shaderErrors.push(`${gl.getShaderInfoLog(vertex)}\n${gl.getShaderInfoLog(fragment)}`);
};

async function loadText(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response.text();
}

// Evaluate `call` (a GLSL expression of vec4 p, and of q and r when a point has 8 or 12 numbers) at every
// point; one fragment per point, read back as float. `include` is one URL or a list; `prelude` goes before
// them (the test's negative control defines LUTBAKE_SCANLINE0_AT_V0 there). `float`: load the EXR as 32-bit
// floats read with texelFetch (NearestFilter: WebGL2 cannot filter float32 textures linearly without
// OES_texture_float_linear), as the exact mode's table needs.
// `float`: false, EXRLoader's defaults (half, linear filtering); true, float32 read by texelFetch (nearest);
// 'linear', float32 with linear filtering (needs OES_texture_float_linear).
async function loadLut(exr, float) {
  const loader = new EXRLoader();
  if (float) loader.setDataType(THREE.FloatType);
  const lut = await loader.loadAsync(exr);
  if (float === true) lut.minFilter = lut.magFilter = THREE.NearestFilter;
  return lut;
}

// `luts`: the textures loaded so far in this call of lutbakeEvaluate, by file and data type (a control job
// reads its LUT's texture again; decoding an EXR in JavaScript is most of a job's time).
async function evaluate({ exr, include, call, points, prelude = '', float = false }, luts) {
  const key = `${exr} ${float}`;
  if (!luts.has(key)) luts.set(key, await loadLut(exr, float));
  const lut = luts.get(key);
  const width = 64;
  const height = Math.ceil(points.length / width);
  const names = ['p', 'q', 'r'].slice(0, Math.ceil(points[0].length / 4));
  const pointTextures = names.map((_, k) => {
    const data = new Float32Array(width * height * 4);
    points.forEach((p, i) => data.set(p.slice(4 * k, 4 * k + 4), 4 * i));
    const texture = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, THREE.FloatType);
    texture.needsUpdate = true;
    return texture;
  });
  const textures = { lut };
  names.forEach((name, k) => { textures[`points_${name}`] = pointTextures[k]; });
  const material = lutbakeMaterial({
    textures,
    includes: [prelude, ...(await Promise.all([].concat(include).map(loadText)))],
    vertexShader: FULLSCREEN_VS,
    body: `layout(location = 0) out highp vec4 colour;
    void main() {
      ${names.map((n) => `highp vec4 ${n} = texelFetch(points_${n}, ivec2(gl_FragCoord.xy), 0);`).join('\n')}
      colour = vec4(${call}, 1.0);
    }`,
  });
  const target = new THREE.WebGLRenderTarget(width, height, {
    type: THREE.FloatType, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter, depthBuffer: false,
  });
  const scene = new THREE.Scene();
  const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material);
  quad.frustumCulled = false;
  scene.add(quad);
  renderer.setRenderTarget(target);
  renderer.render(scene, new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1));
  renderer.setRenderTarget(null);
  if (shaderErrors.length) throw new Error(`shader does not compile: ${shaderErrors.join('\n')}`);
  const pixels = new Float32Array(width * height * 4);
  renderer.readRenderTargetPixels(target, 0, 0, width, height, pixels);
  const rgb = [];
  for (let i = 0; i < points.length; i++) rgb.push(Array.from(pixels.subarray(4 * i, 4 * i + 3)));
  [...pointTextures, target, material].forEach((o) => o.dispose());
  return { exr, texture: { width: lut.image.width, height: lut.image.height, type: lut.type, flipY: lut.flipY }, rgb };
}

window.lutbakeEvaluate = async (jobs) => {
  const gl = renderer.getContext();
  const out = [];
  const luts = new Map();
  for (const job of jobs) out.push(await evaluate(job, luts));
  luts.forEach((lut) => lut.dispose());
  return { renderer: gl.getParameter(gl.RENDERER), three: THREE.REVISION, results: out };
};
window.lutbakeReady = true;

// --- viewer: lit spheres, the film's colour from the shipped include as the Fresnel term -------------
// Each sphere: `sample` is a GLSL expression of (cos_theta, thickness_nm) using texture `lut`; the film
// thickness varies over the sphere (a soap-like swirl between the slice's limits) so its colours show.
const SPHERE_VS = `
out highp vec3 v_normal; out highp vec3 v_view; out highp vec3 v_local;
void main() {
  v_local = position;
  v_normal = normalize(normalMatrix * normal);
  highp vec4 eye = modelViewMatrix * vec4(position, 1.0);
  v_view = -eye.xyz;
  gl_Position = projectionMatrix * eye;
}`;

function sphereBody(sample, thickness) {
  return `in highp vec3 v_normal; in highp vec3 v_view; in highp vec3 v_local;
  layout(location = 0) out highp vec4 colour;
  highp vec3 film(highp float cos_theta, highp float thickness_nm) { return ${sample}; }
  highp vec3 sky(highp vec3 d) {  // a soft studio environment: bright top, dark floor, two softboxes
    highp float up = clamp(d.y * 0.5 + 0.5, 0.0, 1.0);
    highp vec3 c = mix(vec3(0.05), vec3(0.9, 0.95, 1.0), smoothstep(0.3, 1.0, up));
    c += 3.0 * vec3(1.0, 0.97, 0.9) * smoothstep(0.92, 0.97, dot(d, normalize(vec3(-0.6, 0.5, 0.6))));
    c += 1.5 * vec3(0.9, 0.95, 1.0) * smoothstep(0.9, 0.96, dot(d, normalize(vec3(0.7, 0.2, 0.5))));
    return c;
  }
  void main() {
    highp vec3 n = normalize(v_normal), v = normalize(v_view);
    highp float cos_theta = clamp(dot(n, v), 0.0, 1.0);
    highp float swirl = 0.5 + 0.5 * sin(3.0 * v_local.y + 2.0 * sin(4.0 * v_local.x + 1.5 * v_local.z));
    highp float thickness_nm = mix(${thickness[0].toFixed(3)}, ${thickness[1].toFixed(3)}, swirl);
    highp vec3 linear = film(cos_theta, thickness_nm) * sky(reflect(-v, n));
    colour = vec4(pow(clamp(linear / (1.0 + linear), 0.0, 1.0), vec3(1.0 / 2.2)), 1.0);  // Reinhard, ~sRGB
  }`;
}

window.lutbakeView = async (spheres, { size = 256 } = {}) => {
  renderer.setPixelRatio(1);
  renderer.setSize(size * spheres.length, size + 40);
  renderer.setClearColor(0x202020);
  renderer.clear();
  const camera = new THREE.PerspectiveCamera(30, 1, 0.1, 10);
  camera.position.set(0, 0, 4);
  const labels = [];
  for (const [i, s] of spheres.entries()) {
    const material = lutbakeMaterial({
      textures: { lut: await new EXRLoader().loadAsync(s.exr) },
      includes: [await loadText(s.include)],
      vertexShader: SPHERE_VS,
      body: sphereBody(s.sample, s.thickness),
    });
    const scene = new THREE.Scene();
    scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 128, 64), material));
    renderer.setViewport(i * size, 0, size, size);  // the top 40 px stay free for the labels
    renderer.setScissor(i * size, 0, size, size);
    renderer.setScissorTest(true);
    renderer.render(scene, camera);
    labels.push(s.label);
  }
  if (shaderErrors.length) throw new Error(`shader does not compile: ${shaderErrors.join('\n')}`);
  return labels;
};

// --- drop-in comparison: MeshPhysicalMaterial's iridescence by three.js and by lutbake's runtime table, exact mode and a LUT ---
// For each material and mode a sphere is rendered (orthographic, size² pixels) with the film's Fresnel term as
// output, read back as float, together with the parameters each pixel used; a 2D canvas shows the terms
// (sRGB-encoded) in a grid, one row per mode and a row of ground-truth swatches the caller computed.
const DROPIN_MODES = ['three', 'runtime', 'exact', 'lut', 'lut-linear'];   // lut-linear: a LUT by lutRule 'linear'

async function renderOutput(material, size, output) {
  const target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType, depthBuffer: true });
  const scene = new THREE.Scene();
  scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 256, 128), material));
  scene.add(new THREE.DirectionalLight(0xffffff, 1.0));
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

function physicalMaterial(m) {
  const material = new THREE.MeshPhysicalMaterial({
    metalness: m.metal ? 1 : 0, roughness: 0.3, ior: m.ior, iridescence: 1, iridescenceIOR: m.iridescenceIOR,
    iridescenceThicknessMinimum: m.thickness, iridescenceThicknessMaximum: m.thickness });
  // three's metallic base is its colour as F0 (the artist mapping); lutbake takes the metal's n, k.
  if (m.metal) material.color.setRGB(...m.metal.f0, THREE.LinearSRGBColorSpace);
  return material;
}

function encode(v) { return 255 * Math.min(1, Math.max(0, v <= 0.0031308 ? 12.92 * v : 1.055 * v ** (1 / 2.4) - 0.055)); }

window.lutbakeDropin = async ({ materials, swatches, size = 160, stride = 5 }) => {
  const { lutbakeIridescence, loadLutbakeExact, loadLutbakeLut, loadLutbakeRuntime } = await import('./lutbake-iridescence.js');
  const exact = await loadLutbakeExact(materials[0].exact);
  const runtime = await loadLutbakeRuntime(materials[0].runtime, { renderer });   // float32 where this context filters it
  const canvas = document.createElement('canvas');
  const label = 90;
  canvas.width = label + size * materials.length;
  canvas.height = 24 + size * (DROPIN_MODES.length + 1);
  document.body.appendChild(canvas);
  const ctx = canvas.getContext('2d');
  ctx.fillStyle = '#202020';
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  ctx.fillStyle = '#ddd';
  ctx.font = '12px sans-serif';
  ['three.js', 'lutbake runtime', 'lutbake exact', 'lutbake LUT', 'LUT, linear reads', 'ground truth'].forEach((t, i) => ctx.fillText(t, 4, 24 + size * i + size / 2));
  const cells = [];
  for (const [j, m] of materials.entries()) {
    ctx.fillStyle = '#ddd';
    ctx.fillText(m.label, label + size * j + 4, 16);
    const lut = await loadLutbakeLut(m.lut);
    for (const [i, mode] of DROPIN_MODES.entries()) {
      const options = { mode: mode === 'lut-linear' ? 'lut' : mode, lutRule: mode === 'lut-linear' ? 'linear' : null,
                        runtime, exact, lut, metal: m.metal || undefined };
      const fresnel = await renderOutput(lutbakeIridescence(physicalMaterial(m), { ...options, output: 'fresnel' }), size, 'fresnel');
      const params = await renderOutput(lutbakeIridescence(physicalMaterial(m), { ...options, output: 'parameters' }), size, 'parameters');
      const image = ctx.createImageData(size, size);
      const samples = [];
      for (let y = 0; y < size; y++) {
        for (let x = 0; x < size; x++) {
          const k = 4 * ((size - 1 - y) * size + x);   // WebGL rows are bottom-up
          const o = 4 * (y * size + x);
          if (fresnel[k + 3] === 0) { image.data.set([32, 32, 32, 255], o); continue; }
          image.data.set([encode(fresnel[k]), encode(fresnel[k + 1]), encode(fresnel[k + 2]), 255], o);
          if (x % stride === 0 && y % stride === 0) samples.push([...fresnel.subarray(k, k + 3), ...params.subarray(k, k + 3)]);
        }
      }
      ctx.putImageData(image, label + size * j, 24 + size * i);
      cells.push({ material: m.label, mode, samples });
    }
    // Ground-truth swatches: one stripe per cos theta, normal incidence on the left.
    const w = size / swatches[j].length;
    swatches[j].forEach((rgb, s) => {
      ctx.fillStyle = `rgb(${rgb.map(encode).join(',')})`;
      ctx.fillRect(label + size * j + s * w, 24 + size * DROPIN_MODES.length, Math.ceil(w), size);
    });
  }
  return { three: THREE.REVISION, cells, runtimeTable: { precision: runtime.precision, reason: runtime.precisionReason } };
};

// --- cost: wall time of shaders against each other in one page (bench/bench_runtime_cost.py) ---------------
// Every entry is a scene drawn into the same size² float target; entries are interleaved: each round draws
// every entry `draws` times (the order rotates per round) and waits for the GPU (a one-pixel read), so a slow
// stretch of a shared machine hits all of them alike. Returns the wall per draw of every entry and round;
// round 0 (compilation, first upload) is dropped.
function timeInterleaved(entries, { size, rounds, draws }) {
  const target = new THREE.WebGLRenderTarget(size, size, { type: THREE.FloatType, depthBuffer: true });
  const pixel = new Float32Array(4);
  const times = Object.fromEntries(entries.map((e) => [e.name, []]));
  renderer.setRenderTarget(target);
  for (let round = 0; round <= rounds; round++) {
    for (let k = 0; k < entries.length; k++) {
      const { name, scene, camera } = entries[(k + round) % entries.length];
      renderer.readRenderTargetPixels(target, 0, 0, 1, 1, pixel);
      const start = performance.now();
      for (let d = 0; d < draws; d++) renderer.render(scene, camera);
      renderer.readRenderTargetPixels(target, 0, 0, 1, 1, pixel);
      if (round > 0) times[name].push((performance.now() - start) / draws);
    }
    if (shaderErrors.length) throw new Error(`shader does not compile: ${shaderErrors.join('\n')}`);
  }
  renderer.setRenderTarget(null);
  target.dispose();
  return times;
}

// Fragment-shader jobs: one evaluation per pixel of a full-screen pass, parameters from `params` (GLSL of
// gl_FragCoord shared by all jobs, so every job sees the same pixels). `textures`: name -> {exr, float}.
window.lutbakeCost = async ({ textures = {}, params, jobs, size = 512, rounds = 9, draws = 3 }) => {
  const loaded = {};
  for (const [name, t] of Object.entries(textures)) loaded[name] = await loadLut(t.exr, t.float);
  const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0, 1);
  const entries = [];
  for (const job of jobs) {
    const material = lutbakeMaterial({
      textures: loaded,
      includes: [...(await Promise.all((job.includes || []).map(loadText))), job.source || ''],
      vertexShader: FULLSCREEN_VS,
      body: `layout(location = 0) out highp vec4 colour;
      void main() {
        ${params}
        colour = vec4(${job.call}, 1.0);
      }`,
    });
    const scene = new THREE.Scene();
    const quad = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), material);
    quad.frustumCulled = false;
    scene.add(quad);
    entries.push({ name: job.name, scene, camera, material });
  }
  const times = timeInterleaved(entries, { size, rounds, draws });
  entries.forEach((e) => e.material.dispose());
  Object.values(loaded).forEach((t) => t.dispose());
  return { renderer: rendererName(), three: THREE.REVISION, size, times };
};

// The GPU (or CPU rasterizer) behind WebGL and the browser, for the record of a timing.
function rendererName() {
  const gl = renderer.getContext();
  const info = gl.getExtension('WEBGL_debug_renderer_info');
  const name = info ? gl.getParameter(info.UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER);
  return `${name}; ${navigator.userAgent.match(/Chrom\S+/)?.[0] ?? navigator.userAgent}`;
}

// The drop-in on lit MeshPhysicalMaterial spheres filling the view: per material, three.js without
// iridescence (the baseline), with its own iridescence, and the drop-in's modes ('runtime': the table as the
// loader picks it for this context; 'runtime-half': half texels forced). `precision`: what the loader picked.
window.lutbakeDropinCost = async ({ materials, modes, size = 512, rounds = 9, draws = 3 }) => {
  const { lutbakeIridescence, loadLutbakeExact, loadLutbakeLut, loadLutbakeRuntime } = await import('./lutbake-iridescence.js');
  const runtime = await loadLutbakeRuntime(materials[0].runtime, { renderer });
  const half = await loadLutbakeRuntime(materials[0].runtime, { precision: 'half' });
  const sources = { runtime, exact: await loadLutbakeExact(materials[0].exact) };
  const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.1, 10);
  camera.position.set(0, 0, 3);
  const entries = [];
  for (const m of materials) {
    const lut = await loadLutbakeLut(m.lut);
    for (const mode of ['none', 'three', ...modes]) {
      const material = physicalMaterial({ ...m, iridescenceIOR: m.iridescenceIOR });
      if (mode === 'none') material.iridescence = 0;
      else if (mode === 'runtime-half') lutbakeIridescence(material, { mode: 'runtime', runtime: half, metal: m.metal || undefined });
      else if (mode !== 'three') lutbakeIridescence(material, { mode, ...sources, lut, lutRule: m.lutRule, metal: m.metal || undefined });
      const scene = new THREE.Scene();
      scene.add(new THREE.Mesh(new THREE.SphereGeometry(1, 128, 64), material));
      scene.add(new THREE.DirectionalLight(0xffffff, 1.0));
      entries.push({ name: `${m.label}|${mode}`, scene, camera, material });
    }
  }
  const times = timeInterleaved(entries, { size, rounds, draws });
  const report = Object.fromEntries(entries.map((e) => [e.name, e.material.userData.lutbake || null]));
  entries.forEach((e) => e.material.dispose());
  return { three: THREE.REVISION, size, times, precision: { chosen: runtime.precision, reason: runtime.precisionReason }, report };
};
