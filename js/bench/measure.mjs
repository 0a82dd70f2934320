// Measurements of the packages, for docs/js.md:
//   1. size: qm-decoder's wasm (raw, gzip -9) against Draco's decoder wasm
//      (draco_decoder.wasm from npm draco3d, `npm pack draco3d`, and the
//      browser build three.js ships for DRACOLoader);
//   2. speed: the wasm decoder (qm-decoder in Node, the same V8 as Chromium)
//      against the native one (`cargo run --release -p qm-wasm --example
//      bench`) on a whole file, by default the Stanford bunny;
//   3. first visible mesh on a throttled connection (Chromium's network
//      emulation): QMLoader streaming the .qm (whole file, and to a 65 dB
//      goal by maxError) against DRACOLoader loading a Draco file of about
//      65 dB, bytes and milliseconds from the start of the load.
//
//   node bench/measure.mjs [--model OBJ] [--kbps 1000] [--runs 15] [--repeat 3] [--qp Q] [--level 3]
//
// Needs js/build.sh, release builds of qm and the qm-wasm examples, the
// browser test pages (node test/run.mjs browser bundles them) and
// draco_encoder/draco_decoder (Debian's draco). Prints a JSON summary.

import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import zlib from 'node:zlib';
import * as esbuild from 'esbuild';
import { bins, browser, js, out, root, serve } from '../test/harness.mjs';

const args = process.argv.slice(2);
const opt = (name, fallback) => {
  const i = args.indexOf(`--${name}`);
  return i >= 0 ? args[i + 1] : fallback;
};
const model = path.resolve(opt('model', path.join(root, '..', 'shared', 'models', 'stanford-bunny.obj')));
const kbps = Number(opt('kbps', 1000)); // kilobits per second
const runs = Number(opt('runs', 15));
const shownLevel = Number(opt('level', 3));
const repeat = Number(opt('repeat', 3));
const work = path.join(out, 'bench');
fs.mkdirSync(work, { recursive: true });
const name = path.basename(model).replace(/\.[^.]+$/, '');
const median = (xs) => xs.slice().sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const gz = (buf) => zlib.gzipSync(buf, { level: 9 }).length;
const result = { model: path.basename(model) };

// --- 1. sizes --------------------------------------------------------------
const clean = path.join(out, 'clean-web');
if (!fs.existsSync(path.join(clean, 'node_modules', 'qm-decoder'))) {
  console.error('error: run `node test/run.mjs browser` first (it installs the tarballs and bundles the pages)');
  process.exit(1);
}
const qmWasm = fs.readFileSync(path.join(clean, 'node_modules', 'qm-decoder', 'dist', 'qm_decoder_bg.wasm'));
const qmGlue = fs.readFileSync(path.join(clean, 'node_modules', 'qm-decoder', 'dist', 'qm_decoder.js'));
const dracoDir = path.join(work, 'draco3d');
if (!fs.existsSync(path.join(dracoDir, 'package', 'draco_decoder.wasm'))) {
  fs.mkdirSync(dracoDir, { recursive: true });
  const tgz = execFileSync('npm', ['pack', 'draco3d', '--silent', '--pack-destination', dracoDir], { encoding: 'utf8' }).trim().split('\n').pop();
  execFileSync('tar', ['xzf', path.join(dracoDir, tgz), '-C', dracoDir]);
}
const dracoVersion = JSON.parse(fs.readFileSync(path.join(dracoDir, 'package', 'package.json'), 'utf8')).version;
const dracoWasm = fs.readFileSync(path.join(dracoDir, 'package', 'draco_decoder.wasm'));
// DRACOLoader loads the browser build three.js ships (its own wasm and wrapper).
const threeDraco = path.join(clean, 'node_modules', 'three', 'examples', 'jsm', 'libs', 'draco');
const threeWasm = fs.readFileSync(path.join(threeDraco, 'draco_decoder.wasm'));
const threeGlue = fs.readFileSync(path.join(threeDraco, 'draco_wasm_wrapper.js'));
result.size = {
  qm: { wasm: qmWasm.length, wasmGzip: gz(qmWasm), glueGzip: gz(qmGlue) },
  draco3d: { version: dracoVersion, wasm: dracoWasm.length, wasmGzip: gz(dracoWasm) },
  threeDraco: { wasm: threeWasm.length, wasmGzip: gz(threeWasm), glueGzip: gz(threeGlue) },
};
console.error('sizes', JSON.stringify(result.size));

// --- 2. decode speed ---------------------------------------------------------
const qmFile = path.join(work, `${name}.qm`);
if (!fs.existsSync(qmFile)) {
  console.error(`compressing ${model} ...`);
  execFileSync(bins.qm, ['compress', model, '-o', qmFile, '--quiet'], { stdio: 'inherit' });
}
const qmBytes = fs.readFileSync(qmFile);
const nativeRun = JSON.parse(execFileSync(bins.bench, [qmFile, String(runs)], { encoding: 'utf8' }));
const decoder = await import(pathToFileURL(path.join(clean, 'node_modules', 'qm-decoder', 'dist', 'index.js')).href);
await decoder.ready();
const wasmMs = [];
let vertices = 0;
for (let i = 0; i < runs; i++) {
  const t = performance.now();
  const d = new decoder.StreamDecoder({ level: 'finest' });
  d.push(qmBytes);
  const m = d.refine();
  wasmMs.push(performance.now() - t);
  vertices = m.vertexCount;
  d.dispose();
}
result.speed = {
  file: qmBytes.length,
  vertices,
  runs,
  wasmMs: median(wasmMs),
  nativeMs: nativeRun.fullMs,
  ratio: median(wasmMs) / nativeRun.fullMs,
};
console.error('speed', JSON.stringify(result.speed));

// --- 3. first visible mesh, throttled ------------------------------------------
// A Draco file of about 65 dB: the -qp whose decode is nearest 65 dB.
function psnrOf(decoded) {
  return JSON.parse(execFileSync(bins.qm, ['distance', model, decoded, '--json', '--samples', '200000'], { encoding: 'utf8' })).psnr_db;
}
let qp = opt('qp');
const drc = (q) => path.join(work, `${name}-qp${q}.drc`);
const tried = {};
const dracoAt = (q) => {
  if (tried[q]) return tried[q];
  execFileSync('draco_encoder', ['-i', model, '-o', drc(q), '-qp', String(q), '-cl', '10'], { stdio: 'ignore' });
  const obj = path.join(work, `${name}-qp${q}.obj`);
  execFileSync('draco_decoder', ['-i', drc(q), '-o', obj], { stdio: 'ignore' });
  tried[q] = { qp: q, bytes: fs.statSync(drc(q)).size, psnr: psnrOf(obj) };
  console.error('draco', JSON.stringify(tried[q]));
  return tried[q];
};
if (!qp) {
  let best = null;
  for (const q of [8, 9, 10, 11, 12]) {
    const r = dracoAt(q);
    if (!best || Math.abs(r.psnr - 65) < Math.abs(best.psnr - 65)) best = r;
    if (r.psnr > 67) break;
  }
  qp = best.qp;
}
result.draco = dracoAt(Number(qp));

// The qm prefix that reaches 65 dB against the input (for the table), and
// the maxError the loader gets: the decoder's own estimate at that prefix.
const probe = new decoder.StreamDecoder();
probe.push(qmBytes);
const prefixes = [];
for (let n = probe.streamStart; n < qmBytes.length; n = Math.round(n * 1.08)) prefixes.push(n);
probe.dispose();
let qm65 = null;
for (const n of prefixes) {
  const obj = path.join(work, `${name}-${n}.obj`);
  execFileSync(bins.qm, ['decompress', qmFile, '--bytes', String(n), '-o', obj, '--quiet']);
  const psnr = psnrOf(obj);
  fs.rmSync(obj);
  if (psnr >= 65) {
    const m = await decoder.decode(qmBytes, { maxBytes: n });
    qm65 = { bytes: n, psnr, error: m.error, level: m.level, vertices: m.vertexCount };
    break;
  }
}
result.qm65 = qm65;
console.error('qm at 65 dB', JSON.stringify(qm65));

// The page: the test page bundle plus DRACOLoader.
const www = path.join(clean, 'www');
const benchPage = path.join(clean, 'bench.js');
fs.copyFileSync(path.join(js, 'bench', 'bench.js'), benchPage);
fs.copyFileSync(path.join(js, 'bench', 'bench.html'), path.join(www, 'bench.html'));
await esbuild.build({ entryPoints: [benchPage], bundle: true, format: 'esm', target: 'es2022', outdir: www, absWorkingDir: clean, logLevel: 'warning' });
const dracoLib = path.join(www, 'draco');
fs.mkdirSync(dracoLib, { recursive: true });
for (const f of ['draco_decoder.wasm', 'draco_wasm_wrapper.js']) fs.copyFileSync(path.join(threeDraco, f), path.join(dracoLib, f));
fs.copyFileSync(drc(qp), path.join(www, `${name}.drc`));
fs.copyFileSync(qmFile, path.join(www, `${name}.qm`));
const models = path.join(work, 'serve');
fs.mkdirSync(models, { recursive: true });
fs.copyFileSync(qmFile, path.join(models, `${name}.qm`));

const server = await serve(models, { web: www });
// qmStream: the whole file, shown from the first refinement; qmBytes: the
// 65 dB prefix by maxBytes (what a client reading the glTF level table
// asks for); qmError: the same goal as maxError (the decoder's estimate),
// with a wasm binding that estimates errors.
// qmBytesLevel: the same prefix shown at --level (default 3), the level a
// decoder that picks the level the bytes support would choose there.
const loads = { qmStream: [], qmBytes: [], qmBytesLevel: [], draco: [] };
if (qm65 && Number.isFinite(qm65.error)) loads.qmError = [];
try {
  for (let i = 0; i < repeat; i++) {
    for (const kind of Object.keys(loads)) {
      const b = await browser();
      try {
        const cdp = await b.context.newCDPSession(b.page);
        await b.page.goto(`${server.url}bench.html`);
        await b.page.waitForFunction(() => window.qmBench);
        await cdp.send('Network.enable');
        await cdp.send('Network.emulateNetworkConditions', {
          offline: false,
          latency: 40,
          downloadThroughput: (kbps * 1000) / 8,
          uploadThroughput: (kbps * 1000) / 8,
        });
        const r = await b.page.evaluate(
          ([k, file, drcFile, maxError, maxBytes, level]) => window.qmBench.run(k, { qm: file, drc: drcFile, maxError, maxBytes, level }),
          [kind, `${name}.qm`, `${name}.drc`, qm65?.error, qm65?.bytes, shownLevel],
        );
        if (!r.ok) throw new Error(`${kind}: ${r.error}`);
        loads[kind].push(r);
      } finally {
        await b.close();
      }
    }
  }
} finally {
  server.stop();
}
const summary = (xs) => ({
  firstMs: median(xs.map((x) => x.firstMs)),
  firstBytes: median(xs.map((x) => x.firstBytes)),
  firstReceived: median(xs.map((x) => x.firstReceived)),
  firstVertices: median(xs.map((x) => x.firstVertices)),
  doneMs: median(xs.map((x) => x.doneMs)),
  doneBytes: median(xs.map((x) => x.doneBytes)),
  vertices: median(xs.map((x) => x.vertices)),
});
result.throttled = { kbps, latencyMs: 40, repeat };
for (const [kind, xs] of Object.entries(loads)) result.throttled[kind] = summary(xs);
console.log(JSON.stringify(result, null, 2));
