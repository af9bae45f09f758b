// The cost pages' timing (engine/babylon-page.js, playcanvas-page.js; bench/bench_web_engines.py): every entry
// drawn `draws` times per round, rounds interleaved with the order rotating, each draw batch bracketed by
// `wait` (a one-pixel read: the GPU is done), so a slow stretch of a shared machine hits every entry alike;
// round 0 (compilation, first uploads) is dropped. Returns {entry name: [ms per draw, one per round]}.
export async function interleavedTimes(entries, { show, wait, draw, rounds, draws }) {
  const times = Object.fromEntries(entries.map((e) => [e.name, []]));
  for (let round = 0; round <= rounds; round++) {
    for (let i = 0; i < entries.length; i++) {
      const entry = entries[(i + round) % entries.length];
      show(entry);
      await wait();
      const start = performance.now();
      for (let d = 0; d < draws; d++) draw();
      await wait();
      if (round > 0) times[entry.name].push((performance.now() - start) / draws);
    }
  }
  return times;
}
