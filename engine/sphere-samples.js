// The test pages' read-back (babylon-page.js, playcanvas-page.js): a sphere's Fresnel term and the
// parameters each pixel used, two size² RGBA float renders, as [r, g, b, cos theta, thickness nm, film index]
// rows of every `stride`-th pixel the sphere covers (alpha > 0).
export function coveredSamples(fresnel, params, size, stride) {
  const samples = [];
  for (let i = 0; i < size * size; i += stride) {
    if (fresnel[4 * i + 3] > 0) samples.push([...fresnel.subarray(4 * i, 4 * i + 3), ...params.subarray(4 * i, 4 * i + 3)]);
  }
  return samples;
}

// Each material a glTF asset loaded twice (output 'fresnel', then 'parameters': the same materials in the
// same order) rendered by `render(material)`: its `describe(material)` and its samples.
export async function gltfCells(load, render, describe, size, stride) {
  const [fresnels, parameters] = [await load('fresnel'), await load('parameters')];
  const cells = [];
  for (const [k, material] of fresnels.entries()) {
    const samples = coveredSamples(await render(material, size), await render(parameters[k], size), size, stride);
    cells.push({ ...describe(material), samples });
  }
  return cells;
}
