// Time to first picture and decode throughput, browser (WebAssembly) against
// native, for bundled models:
//
//   node web/test/measure.mjs [--repeat N] [MODEL.obj ...]   (default: assets/spot.obj)
//
// For each model: compresses it; loads the viewer from `qm serve`
// unthrottled and throttled (64 KB/s) and reads the time to first picture
// (from navigation start to the first frame that shows a mesh, page and
// WebAssembly loading included); runs the page's benchmark (the whole file
// decoded from scratch by a new decoder, 15 runs, median) and the same
// incremental decoder natively (`qm-wasm` example `bench`). Repeats all of
// it N times and prints a Markdown table of medians. Needs what the browser test needs (see .ci/web).

import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { bins, browser, compress, scratch, serve } from './harness.mjs';

const args = process.argv.slice(2);
const at = args.indexOf('--repeat');
const REPEAT = at >= 0 ? Number(args.splice(at, 2)[1]) : 1;
const models = args.length ? args : ['assets/spot.obj'];
const RUNS = 15;

async function ttfp(file, throttle) {
  const server = await serve(file, { throttle });
  const b = await browser();
  try {
    await b.page.goto(server.url);
    await b.page.waitForFunction(() => window.qmViewer?.state.ttfpMs !== null || window.qmViewer?.state.error, null, { timeout: 120000 });
    const s = await b.page.evaluate(() => ({ ...window.qmViewer.state, history: undefined }));
    if (s.error) throw new Error(s.error);
    // From the request for the file to the first picture.
    s.ttfpFetchMs = s.ttfpMs - s.fetchMs;
    await b.page.waitForFunction(() => window.qmViewer.state.done, null, { timeout: 300000 });
    const bench = throttle ? null : await b.page.evaluate((runs) => window.qmViewer.bench(runs), RUNS);
    const end = await b.page.evaluate(() => window.qmViewer.state.refinements);
    return { ttfpMs: s.ttfpMs, ttfpFetchMs: s.ttfpFetchMs, firstBytes: s.ttfpBytes, bench, refinements: end };
  } finally {
    await b.close();
    server.stop();
  }
}

const rows = [];
for (let repeat = 0; repeat < REPEAT; repeat++) {
  for (const [m, model] of models.entries()) {
    const dir = scratch('measure');
    const file = path.join(dir, `${path.basename(model, path.extname(model))}.qm`);
    const bytes = compress(model, file);
    const fast = await ttfp(file, 0);
    const slow = await ttfp(file, 64);
    const native = JSON.parse(execFileSync(bins.bench, [file, String(RUNS)], { encoding: 'utf8' }));
    (rows[m] ??= []).push({ model, bytes: bytes.length, vertices: fast.bench.vertices, fast, slow, wasm: fast.bench, native });
    fs.rmSync(dir, { recursive: true, force: true });
  }
}

// Medians over the repeats (and the range of the time ratio).
const median = (xs) => xs.slice().sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const f = (x, d = 1) => x.toFixed(d);
console.log(`${REPEAT} repeats, medians; load average ${os.loadavg().map((l) => l.toFixed(1)).join(', ')} at the end`);
console.log('| model | file | vertices | first picture, localhost: from navigation (from request) | first picture, 64 KB/s: from request | base mesh decode, wasm / native | whole file decode, wasm / native | wasm / native time | wasm: MB/s, M vertices/s | native: MB/s, M vertices/s |');
console.log('|---|---|---|---|---|---|---|---|---|---|');
for (const r of rows) {
  const g = (fn) => median(r.map(fn));
  const ratios = r.map((x) => x.wasm.fullMs / x.native.fullMs);
  console.log(`| ${path.basename(r[0].model, path.extname(r[0].model))} | ${r[0].bytes.toLocaleString('en')} B | ${r[0].vertices.toLocaleString('en')} | ${f(g((x) => x.fast.ttfpMs), 0)} ms (${f(g((x) => x.fast.ttfpFetchMs), 0)} ms) | ${f(g((x) => x.slow.ttfpFetchMs), 0)} ms | ${f(g((x) => x.wasm.baseMs), 2)} / ${f(g((x) => x.native.baseMs), 2)} ms | ${f(g((x) => x.wasm.fullMs))} / ${f(g((x) => x.native.fullMs))} ms | ${f(median(ratios), 2)} (${f(Math.min(...ratios), 2)} to ${f(Math.max(...ratios), 2)}) | ${f(g((x) => x.wasm.mbPerS), 2)}, ${f(g((x) => x.wasm.verticesPerS) / 1e6, 2)} | ${f(g((x) => x.native.mbPerS), 2)}, ${f(g((x) => x.native.verticesPerS) / 1e6, 2)} |`);
}
console.error(JSON.stringify(rows, null, 1));
