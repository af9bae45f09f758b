// Checks that EXR + include pairs are members of one lutbake set, as engine/lutbake-iridescence.js's loaders
// do before sampling (checkSameSet). Usage: node engine/check-set.mjs STEM.exr STEM.glsl [more pairs]
// Prints one JSON line per pair: {"ok": true} or {"ok": false, "error": "..."}; exit 1 if any pair fails.
import { readFileSync } from 'node:fs';
import { EXRLoader } from 'three/addons/loaders/EXRLoader.js';
import { checkSameSet } from './lutbake-iridescence.js';

let failed = false;
const args = process.argv.slice(2);
for (let i = 0; i < args.length; i += 2) {
  const [exr, include] = [args[i], args[i + 1]];
  try {
    const bytes = readFileSync(exr);
    const { header } = new EXRLoader().parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength));
    checkSameSet(header, readFileSync(include, 'utf8'), exr);
    console.log(JSON.stringify({ ok: true }));
  } catch (error) {
    failed = true;
    console.log(JSON.stringify({ ok: false, error: String(error.message || error) }));
  }
}
process.exit(failed ? 1 : 0);
