// The test pages' read-back (babylon-page.js, playcanvas-page.js): a sphere's Fresnel term and the
// parameters each pixel used, two size² RGBA float renders, as [r, g, b, cos theta, thickness nm, film index]
// rows of every `stride`-th pixel the sphere covers (alpha > 0); with `more` (renders of outputs 'basecolor' and
// 'metallic') the row goes on with the pixel's base colour and metallic weight.
export function coveredSamples(fresnel, params, size, stride, more = null) {
  const samples = [];
  for (let i = 0; i < size * size; i += stride) {
    if (fresnel[4 * i + 3] <= 0) continue;
    const row = [...fresnel.subarray(4 * i, 4 * i + 3), ...params.subarray(4 * i, 4 * i + 3)];
    samples.push(more ? [...row, ...more.base.subarray(4 * i, 4 * i + 3), more.metallic[4 * i]] : row);
  }
  return samples;
}

// One material's sphere in one mode: its samples, and with `image` the whole size² Fresnel and parameter
// renders (RGBA floats, rows in the engine's read-back order: docs/make_engines_figure.py draws them).
export function sphereCell(material, mode, fresnel, params, size, stride, image) {
  const cell = { material, mode, samples: coveredSamples(fresnel, params, size, stride) };
  return image ? { ...cell, image: Array.from(fresnel), parameters: Array.from(params) } : cell;
}

// Each material in each mode on the sphere, rendered twice by `render(material, size)`: with the drop-in's
// output 'fresnel', then 'parameters' (`attach(material, options)` is the engine's drop-in, `make(m, k)` its
// material of spec material m); the cells of sphereCell.
export async function sphereCells({ materials, modes, runtime, make, attach, render, size, stride, image }) {
  const cells = [];
  for (const [k, m] of materials.entries()) {
    for (const mode of modes) {
      const options = { runtime, mode, metal: m.metal || undefined };
      const fresnel = await render(attach(make(m, k), { ...options, output: 'fresnel' }), size);
      const params = await render(attach(make(m, k), { ...options, output: 'parameters' }), size);
      cells.push(sphereCell(k, mode, fresnel, params, size, stride, image));
    }
  }
  return cells;
}

// RGBA bytes of a 64 x 32 film thickness texture, random per texel (the glTF thickness texture's G).
export function thicknessWeights(seed) {
  const data = new Uint8Array(64 * 32 * 4);
  let state = seed >>> 0;
  for (let i = 0; i < data.length; i++) {
    state = (1664525 * state + 1013904223) >>> 0;
    data[i] = state >>> 24;
  }
  return data;
}

const GLTF_OUTPUTS = ['fresnel', 'parameters', 'basecolor', 'metallic'];

// Each material a glTF asset loaded four times (outputs 'fresnel', 'parameters', 'basecolor', 'metallic': the
// same materials in the same order) rendered by `render(material)`: its `describe(material)` and its samples
// ([r, g, b, cos theta, thickness nm, film index, base r, g, b, metallic]).
export async function gltfCells(load, render, describe, size, stride) {
  const loads = [];
  for (const output of GLTF_OUTPUTS) loads.push(await load(output));
  const cells = [];
  for (const [k, material] of loads[0].entries()) {
    const renders = [];
    for (const materials of loads) renders.push(await render(materials[k], size));
    const [fresnel, params, base, metallic] = renders;
    cells.push({ ...describe(material), samples: coveredSamples(fresnel, params, size, stride, { base, metallic }) });
  }
  return cells;
}
