// PlayCanvas's StandardMaterial with lutbake's runtime table in headless Chromium (engine/harness.mjs
// playcanvas, tests/engines/test_playcanvas_engine.py): per material, a sphere rendered into a float target
// with the film's Fresnel term as output and again with the parameters each pixel used, for PlayCanvas's own
// term and lutbake's.
import * as pc from 'playcanvas';
import { loadLutbakeRuntime, lutbakeIridescence } from './lutbake-playcanvas.js';

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

// One film thickness per material (thickness min = max): with iridescenceThicknessMap set, PlayCanvas 2.23.3's
// shader does not compile here (texture_iridescenceThicknessMap undeclared), so the films vary by material.
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

window.lutbakePlaycanvas = async ({ runtime: stem, materials, modes, size = 96, stride = 2 }) => {
  const runtime = await loadLutbakeRuntime(stem, device);
  const cells = [];
  for (const [k, m] of materials.entries()) {
    for (const mode of modes) {
      const options = { runtime, mode, metal: m.metal || undefined, device };
      const fresnel = await render(lutbakeIridescence(standardMaterial(m), { ...options, output: 'fresnel' }), size);
      const params = await render(lutbakeIridescence(standardMaterial(m), { ...options, output: 'parameters' }), size);
      const samples = [];
      for (let i = 0; i < size * size; i += stride) {
        if (fresnel[4 * i + 3] > 0) samples.push([...fresnel.subarray(4 * i, 4 * i + 3), ...params.subarray(4 * i, 4 * i + 3)]);
      }
      cells.push({ material: k, mode, samples });
    }
  }
  const { format, mipmaps, anisotropy, minFilter, magFilter, addressU, addressV } = runtime.table;
  return { playcanvas: pc.version, device: device.deviceType, renderer: device.unmaskedRenderer ?? '',
           texture: { format, mipmaps, anisotropy, minFilter, magFilter, addressU, addressV }, cells };
};
window.lutbakeReady = true;
