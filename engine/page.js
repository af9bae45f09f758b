// The engine side of tests/test_engine.py and of the viewer: three.js loads lutbake's files with its
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
async function evaluate({ exr, include, call, points, prelude = '', float = false }) {
  const loader = new EXRLoader();
  if (float) loader.setDataType(THREE.FloatType);
  const lut = await loader.loadAsync(exr);
  if (float) lut.minFilter = lut.magFilter = THREE.NearestFilter;
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
  [lut, ...pointTextures, target, material].forEach((o) => o.dispose());
  return { exr, texture: { width: lut.image.width, height: lut.image.height, type: lut.type, flipY: lut.flipY }, rgb };
}

window.lutbakeEvaluate = async (jobs) => {
  const gl = renderer.getContext();
  const out = [];
  for (const job of jobs) out.push(await evaluate(job));
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
