// Runs engine/page.html in headless Chromium (Debian's package) against a server bound to 127.0.0.1.
// Usage: node engine/harness.mjs evaluate JOBS.json RESULT.json   (tests/engines/test_engine.py)
//        node engine/harness.mjs cost SPEC.json RESULT.json        (bench/bench_runtime_cost.py: shader wall times)
//        node engine/harness.mjs dropin-cost SPEC.json RESULT.json (bench/bench_runtime_cost.py: the drop-in's)
//        node engine/harness.mjs view SPHERES.json IMAGE.png       (docs/make_hero.py, lutbake preview)
//        node engine/harness.mjs dropin SPEC.json RESULT.json IMAGE.png   (tests/engines/test_exact_engine.py)
//        node engine/harness.mjs gltf SPEC.json RESULT.json               (tests/engines/test_gltf_engine.py)
//        node engine/harness.mjs babylon SPEC.json RESULT.json            (tests/engines/test_web_engines.py)
//        node engine/harness.mjs playcanvas SPEC.json RESULT.json         (tests/engines/test_web_engines.py)
//        node engine/harness.mjs babylon-gltf SPEC.json RESULT.json       (tests/engines/test_web_engines.py)
//        node engine/harness.mjs webgpu SPEC.json RESULT.json             (tests/engines/test_webgpu_engine.py)
//        node engine/harness.mjs webgpu-cost SPEC.json RESULT.json        (bench/bench_web_engines.py cost)
//        node engine/harness.mjs babylon-gltf-cost SPEC.json RESULT.json  (bench/bench_web_engines.py gltf-cost)
// The server serves the repository's files read-only; nothing outside the repository is reachable.
import { createServer } from 'node:http';
import { mkdtempSync, readFileSync, renameSync, rmSync, writeFileSync, existsSync, statSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { extname, join, resolve, sep } from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

const ROOT = resolve(fileURLToPath(new URL('..', import.meta.url)));
const CHROMIUM = process.env.LUTBAKE_CHROMIUM || '/usr/bin/chromium';
const TYPES = { '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
                '.gltf': 'model/gltf+json', '.png': 'image/png' };

function serve() {
  const server = createServer((req, res) => {
    const path = resolve(join(ROOT, decodeURIComponent(new URL(req.url, 'http://x').pathname)));
    if (!path.startsWith(ROOT + sep) || !existsSync(path) || !statSync(path).isFile()) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'Content-Type': TYPES[extname(path)] || 'application/octet-stream' });
    res.end(readFileSync(path));
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

// WebGL2 pages run with the GPU process off (SwiftShader's GL); WebGPU pages need it on, with WebGPU
// allowed on SwiftShader's Vulkan (headless Chromium has no adapter otherwise; docs/engines.md).
const FLAGS = { webgl: ['--disable-gpu', '--enable-unsafe-swiftshader'], webgpu: ['--enable-unsafe-webgpu', '--enable-unsafe-swiftshader'] };

async function withPage(fn, pagePath = '/engine/page.html', api = 'webgl') {
  if (!existsSync(CHROMIUM)) throw new Error(`${CHROMIUM} not found: install Debian's chromium (apt-get install chromium)`);
  const server = await serve();
  const profile = mkdtempSync(join(tmpdir(), 'lutbake-chromium-'));
  // A fresh profile (--user-data-dir) per run; playwright passes it for launchPersistentContext.
  const browser = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    viewport: { width: 1200, height: 400 },
    args: ['--no-sandbox', ...FLAGS[api], '--disable-quic', '--no-first-run',
           '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  try {
    const page = await browser.newPage();
    const errors = [];
    page.on('pageerror', (e) => errors.push(String(e)));
    page.on('console', (m) => { if (m.type() === 'error' || m.type() === 'warning') console.error(m.text()); });
    await page.goto(`http://127.0.0.1:${server.address().port}${pagePath}`);
    await page.waitForFunction(() => window.lutbakeReady === true || null, null, { timeout: 30000 })
      .catch(() => { throw new Error(`page did not load: ${errors.join('; ')}`); });
    return await fn(page, errors);
  } finally {
    await browser.close();
    server.close();
    rmSync(profile, { recursive: true, force: true });
  }
}

// Write beside the destination, then rename: a reader never sees a partial file.
function writeAtomic(path, data) {
  const tmp = `${path}.tmp-${process.pid}`;
  writeFileSync(tmp, data);
  renameSync(tmp, path);
}

// Commands that hand a JSON spec to one page function and write its JSON result: [function, page, api].
const CALLS = { evaluate: ['lutbakeEvaluate'], cost: ['lutbakeCost'], 'dropin-cost': ['lutbakeDropinCost'],
                gltf: ['lutbakeGltf', '/engine/gltf-page.html'], 'gltf-grid': ['lutbakeGltfGrid', '/engine/gltf-page.html'], babylon: ['lutbakeBabylon', '/engine/babylon-page.html'],
                playcanvas: ['lutbakePlaycanvas', '/engine/playcanvas-page.html'],
                'babylon-gltf': ['lutbakeBabylonGltf', '/engine/babylon-page.html'],
                'babylon-cost': ['lutbakeBabylonCost', '/engine/babylon-page.html'],
                'playcanvas-cost': ['lutbakePlaycanvasCost', '/engine/playcanvas-page.html'],
                'playcanvas-gltf': ['lutbakePlaycanvasGltf', '/engine/playcanvas-page.html'],
                'babylon-gltf-cost': ['lutbakeBabylonGltfCost', '/engine/babylon-page.html'],
                'playcanvas-gltf-cost': ['lutbakePlaycanvasGltfCost', '/engine/playcanvas-page.html'],
                webgpu: ['lutbakeWebgpu', '/engine/webgpu-page.html', 'webgpu'],
                'webgpu-cost': ['lutbakeWebgpuCost', '/engine/webgpu-page.html', 'webgpu'] };

const [command, input, output] = process.argv.slice(2);
if (command in CALLS) {
  const spec = JSON.parse(readFileSync(input, 'utf8'));
  const [fn, pagePath, api] = CALLS[command];
  const result = await withPage(async (page, errors) => {
    try {
      return await page.evaluate(([name, s]) => window[name](s), [fn, spec]);
    } catch (e) {
      throw new Error(`${e.message}\n${errors.join('\n')}`);
    }
  }, pagePath, api);
  writeAtomic(output, JSON.stringify(result));
} else if (command === 'view') {
  const spheres = JSON.parse(readFileSync(input, 'utf8'));
  await withPage(async (page) => {
    const labels = await page.evaluate((s) => window.lutbakeView(s), spheres);
    await page.evaluate((names) => {
      const row = document.createElement('div');
      row.style = 'position:absolute;left:0;top:0;display:flex;font:14px sans-serif;color:#ddd';
      for (const name of names) row.insertAdjacentHTML('beforeend', `<div style="width:256px;text-align:center;padding-top:12px">${name}</div>`);
      document.body.appendChild(row);
    }, labels);
    writeAtomic(output, await page.locator('canvas').screenshot());
  });
} else if (command === 'dropin') {
  const spec = JSON.parse(readFileSync(input, 'utf8'));
  const result = await withPage(async (page, errors) => {
    try {
      const out = await page.evaluate((s) => window.lutbakeDropin(s), spec);
      writeAtomic(process.argv[5], await page.locator('body > canvas').last().screenshot());
      return out;
    } catch (e) {
      throw new Error(`${e.message}\n${errors.join('\n')}`);
    }
  });
  writeAtomic(output, JSON.stringify(result));
} else {
  console.error('usage: node engine/harness.mjs evaluate|cost|dropin-cost SPEC.json RESULT.json | view SPHERES.json IMAGE.png | dropin SPEC.json RESULT.json IMAGE.png | gltf SPEC.json RESULT.json');
  process.exit(2);
}
