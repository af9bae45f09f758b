// lutbake's tables for engines without a usable EXR loader (Babylon.js's needs fflate from a CDN, PlayCanvas
// has none): a bounded reader of the half-float EXRs lutbake writes (scanline, ZIP or uncompressed, HALF
// channels; lutbake/tables/exr.py; the runtime table is always RGBA half) with no dependency but the browser's
// DecompressionStream, and the loaders of the runtime table, a glTF bake's atlas and its 4D LUTs on top of it.
// Engine-neutral: it returns texels and the include, the engine's file uploads them.
//
//   import { loadRuntimeTable } from './lutbake-exr.js';
//   const { width, height, texels, include } = await loadRuntimeTable('luts/runtime/lutbake-runtime');
//   // texels: Uint16Array of RGBA half floats, scanline 0 first (row 0 at v = 0 in WebGL's upload order):
//   // the include must then be compiled after #define LUTBAKE_SCANLINE0_AT_V0 1.

const MAGIC = 20000630;
const MAX_HEADER_BYTES = 1 << 20;        // lutbake's headers are a few kB (the metadata JSON included)
const MAX_TEXELS = 1 << 24;              // 16 Mtexels: the runtime table is 1056 x 396
const COMPRESSION = { 0: 'none', 3: 'zip' };  // ZIP: 16 scanlines per block; ZIPS (2) is not written by lutbake
const LINES_PER_BLOCK = { none: 1, zip: 16 };
const HALF = 1;                          // OpenEXR's pixel type: the only one the runtime table uses

function fail(url, what) { throw new Error(`${url}: ${what}`); }

function cString(bytes, at, end, url) {
  const stop = bytes.indexOf(0, at);
  if (stop < 0 || stop >= end) fail(url, 'not an OpenEXR file (unterminated header name)');
  return [new TextDecoder().decode(bytes.subarray(at, stop)), stop + 1];
}

function channelList(bytes, view, at, end, url) {
  const channels = [];
  while (bytes[at] !== 0) {
    const [name, next] = cString(bytes, at, end, url);
    const type = view.getInt32(next, true);
    if (type !== HALF) fail(url, `channel ${name} has pixel type ${type}; the runtime table is HALF (1)`);
    channels.push({ name, type });
    at = next + 16;
  }
  return channels;  // OpenEXR stores them sorted by name: the order of the planes in a scanline
}

// The header attributes lutbake's tables need: channels, compression, dataWindow, lineOrder, and every
// string attribute (lutbake.*) as text.
function readHeader(bytes, view, url) {
  if (bytes.length < 8 || view.getUint32(0, true) !== MAGIC) fail(url, 'not an OpenEXR file');
  // Version flags (bits 9-12): tiled, long names, deep, multi-part. Long names (attribute and channel names up
  // to 255 bytes; a scene atlas's header has them) read as any name does.
  if (view.getUint8(5) & 0x1a) fail(url, 'a tiled, deep or multi-part EXR; lutbake writes single-part scanline files');
  const end = Math.min(bytes.length, MAX_HEADER_BYTES);
  const header = {};
  let at = 8;
  while (at < end && bytes[at] !== 0) {
    const [name, afterName] = cString(bytes, at, end, url);
    const [type, afterType] = cString(bytes, afterName, end, url);
    const size = view.getInt32(afterType, true);
    const value = afterType + 4;
    if (size < 0 || value + size > end) fail(url, `header attribute ${name} of ${size} bytes runs past the header`);
    if (type === 'chlist') header[name] = channelList(bytes, view, value, value + size, url);
    else if (type === 'compression' || type === 'lineOrder') header[name] = bytes[value];
    else if (type === 'box2i') header[name] = [0, 1, 2, 3].map((k) => view.getInt32(value + 4 * k, true));
    else if (type === 'string') header[name] = new TextDecoder().decode(bytes.subarray(value, value + size));
    at = value + size;
  }
  if (at >= end) fail(url, `header longer than ${MAX_HEADER_BYTES} bytes or unterminated`);
  return { header, pixelsAt: at + 1 };
}

async function inflate(block) {
  const stream = new Blob([block]).stream().pipeThrough(new DecompressionStream('deflate'));
  return new Uint8Array(await new Response(stream).arrayBuffer());
}

// OpenEXR's ZIP filter, undone: byte deltas, then the two halves of the block interleaved.
function unpredict(data) {
  for (let i = 1; i < data.length; i++) data[i] = (data[i - 1] + data[i] - 128) & 0xff;
  const out = new Uint8Array(data.length);
  const half = (data.length + 1) >> 1;
  for (let i = 0; i < data.length; i++) out[i] = i & 1 ? data[half + (i >> 1)] : data[i >> 1];
  return out;
}

// The pixels of a scanline EXR as RGBA half floats, scanline 0 first. Every block is checked against the
// bounds the header declared before anything is allocated from it.
export async function readExr(url, buffer) {
  const bytes = new Uint8Array(buffer);
  const view = new DataView(buffer);
  const { header, pixelsAt } = readHeader(bytes, view, url);
  const compression = COMPRESSION[header.compression];
  if (!compression) fail(url, `compression ${header.compression}; lutbake writes ZIP (3) or none (0)`);
  const [x0, y0, x1, y1] = header.dataWindow || fail(url, 'no dataWindow');
  const width = x1 - x0 + 1;
  const height = y1 - y0 + 1;
  if (!(width > 0 && height > 0 && width * height <= MAX_TEXELS)) fail(url, `${width} x ${height} texels; at most ${MAX_TEXELS}`);
  const channels = header.channels || fail(url, 'no channels');
  const rgba = ['R', 'G', 'B', 'A'].map((name) => channels.findIndex((c) => c.name === name));
  if (rgba.slice(0, 3).includes(-1)) fail(url, 'no R, G and B channels');
  const lineBytes = channels.length * width * 2;
  const lines = LINES_PER_BLOCK[compression];
  const blocks = Math.ceil(height / lines);
  if (pixelsAt + 8 * blocks > bytes.length) fail(url, `the offset table of ${blocks} blocks runs past the end of the file`);
  const texels = new Uint16Array(width * height * 4);
  for (let b = 0; b < blocks; b++) {
    const offset = Number(view.getBigUint64(pixelsAt + 8 * b, true));
    if (offset + 8 > bytes.length) fail(url, `block ${b} starts past the end of the file`);
    const first = view.getInt32(offset, true) - y0;
    const size = view.getInt32(offset + 4, true);
    const count = Math.min(lines, height - first);
    if (first !== b * lines || size < 0 || offset + 8 + size > bytes.length) fail(url, `block ${b} is damaged`);
    const packed = bytes.subarray(offset + 8, offset + 8 + size);
    const data = size < count * lineBytes ? unpredict(await inflate(packed)) : packed;
    if (data.length !== count * lineBytes) fail(url, `block ${b} holds ${data.length} bytes, not ${count * lineBytes}`);
    const block = new DataView(data.buffer, data.byteOffset, data.byteLength);
    for (let line = 0; line < count; line++) {
      let plane = line * lineBytes;
      const row = (first + line) * width * 4;
      channels.forEach((c) => {
        const slot = rgba.indexOf(channels.indexOf(c));
        for (let x = 0; slot >= 0 && x < width; x++) {
          texels[row + 4 * x + slot] = block.getUint16(plane + 2 * x, true);
        }
        plane += width * 2;
      });
      if (rgba[3] < 0) for (let x = 0; x < width; x++) texels[row + 4 * x + 3] = 0x3c00;  // alpha 1
    }
  }
  return { width, height, header, texels };
}

async function fetchOk(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  return response;
}

// STEM.exr's texels and header, and the include STEM.glsl beside it.
async function loadExrAndInclude(stem) {
  const [buffer, include] = await Promise.all([
    fetchOk(`${stem}.exr`).then((r) => r.arrayBuffer()), fetchOk(`${stem}.glsl`).then((r) => r.text())]);
  return { ...(await readExr(`${stem}.exr`, buffer)), include };
}

// A glTF bake's atlas (`lutbake bake --gltf`: STEM.exr, STEM.glsl), checked to be one set (the include's first
// line names the start of the header's scene hash).
export async function loadSceneAtlas(stem) {
  const atlas = await loadExrAndInclude(stem);
  const named = atlas.include.match(/^\/\/ lutbake scene material table \(scene hash ([0-9a-f]+)\)/);
  const hash = atlas.header['lutbake.scene_hash'];
  if (!named || typeof hash !== 'string' || !hash.startsWith(named[1])) {
    fail(stem, `the EXR (scene hash ${hash}) and its include (${named ? named[1] : 'no scene hash'}) are not one bake: bake the scene again`);
  }
  return atlas;
}

// A table whose include names the EXR header's content hash on its second line, checked to be one set of
// `format` (a folder copied mid-bake could pair two bakes): `again` says how to make one.
async function loadHashedTable(stem, format, again) {
  const { include, ...table } = await loadExrAndInclude(stem);
  if (table.header['lutbake.format'] !== format) fail(stem, `not a ${format} table (lutbake.format)`);
  const named = include.match(/^\/\/ content hash ([0-9a-f]+);/m);
  if (!named || named[1] !== table.header['lutbake.content_hash']) {
    fail(stem, `the EXR (hash ${table.header['lutbake.content_hash']}) and its include (${named ? named[1] : 'no hash'}) `
      + `are of different bakes (copied or interrupted mid-commit): ${again}`);
  }
  return { ...table, include };
}

// `lutbake runtime-table`'s STEM.exr and STEM.glsl.
export const loadRuntimeTable = (stem) => loadHashedTable(stem, 'lutbake-runtime', 'run lutbake runtime-table again');

// A baked 4D LUT's STEM.exr and STEM.glsl (a glTF bake's texture-driven metal), with the constant its include
// defines (`ident`).
export async function loadLutTable(stem) {
  const lut = await loadHashedTable(stem, 'lutbake-lut', 'bake again');
  const ident = lut.include.match(/^const LutbakeLut (\w+) =/m) || fail(stem, 'its include defines no LutbakeLut constant');
  return { ...lut, ident: ident[1] };
}
