// three-qm-loader and qm-decoder in headless Chromium (Debian's package,
// driven by playwright-core), on a page bundled from the installed tarballs
// (js/test/run.mjs) and served with the .qm files by `qm serve`:
//   - a throttled spot.qm streams into one BufferGeometry: the first
//     refinement comes before the download completes, and the final
//     geometry equals `qm decompress` of the same bytes at the same level;
//   - corrupt, header-truncated and bomb files reject the loader's promise
//     with a QMError naming the problem while the page keeps rendering;
//   - with maxBytes the server sends that prefix and no more (plus one
//     request's slack), and resume() goes on by Range;
//   - an abort rejects with the signal's reason;
//   - qm-decoder decodes on the main thread and in a module worker;
//   - a GLB with QM_progressive_mesh shows its fallback with plain GLTFLoader
//     and streams to the full mesh with the plugin;
//   - a coloured file gives qm-decoder's colours at every refinement (the
//     native decoder's) and the loader's geometry a color attribute in
//     step, which three.js turns back into the input's sRGB bytes.
//
// Environment: QM_WWW, the bundled pages (set by run.mjs).

import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { after, before, test } from 'node:test';
import { bins, browser, coloured, compress, fnv1a, logsRequests, reference, requests, root, scratch, serve } from '../harness.mjs';
import validator from 'gltf-validator';

const www = process.env.QM_WWW;
assert.ok(www && fs.existsSync(path.join(www, 'loader.html')), 'QM_WWW must hold the bundled pages: run js/test/run.mjs');

let dir;
let spot;
let cube;
let throttled; // qm serve --throttle, the spot file
let fast; // qm serve unthrottled, the cube file
let slow; // qm serve throttled harder, a textured controller
let picoFile; // that controller's file
let b;
let colouredFile;
let texturedFile; // the coloured example's sphere, served throttled

// `qm decompress` of the first `bytes` at `level`, as f32 positions and quads.
function native(file, bytes, level, extra = []) {
  const obj = path.join(dir, `native-${bytes}-${level}${extra.join('')}.obj`);
  execFileSync(bins.qm, ['decompress', file, '--bytes', String(bytes), '--level', String(level), ...extra, '-o', obj, '--quiet']);
  const positions = [];
  const quads = [];
  for (const line of fs.readFileSync(obj, 'utf8').split('\n')) {
    const f = line.trim().split(/\s+/);
    if (f[0] === 'v') positions.push(...f.slice(1, 4).map((x) => Math.fround(Number(x))));
    if (f[0] === 'f') quads.push(f.slice(1).map((c) => Number(c.split('/')[0]) - 1));
  }
  return { positions, quads };
}

function assertEqualsNative(file, result, bytes, level, extra = []) {
  const n = native(file, bytes, level, extra);
  assert.equal(result.positions.length, n.positions.length, `vertex count at ${bytes} bytes, level ${level}`);
  let mismatched = 0;
  for (let i = 0; i < n.positions.length; i++) if (n.positions[i] !== result.positions[i]) mismatched++;
  assert.equal(mismatched, 0, `positions equal qm decompress --bytes ${bytes} --level ${level} (as f32)`);
  assert.equal(result.indices.length, 6 * n.quads.length);
  n.quads.forEach(([a, b2, c, d], k) => {
    const t = result.indices.slice(6 * k, 6 * k + 6);
    assert.deepEqual(t, [a, b2, c, a, c, d], `quad ${k}`);
  });
}

async function page(server) {
  b.errors.length = 0;
  await b.page.goto(`${server.url}loader.html`);
  await b.page.waitForFunction(() => window.qmTest && window.qmTest.frames() > 2);
}

before(async () => {
  dir = scratch('browser');
  const models = path.join(dir, 'models');
  fs.mkdirSync(models);
  spot = { file: path.join(models, 'spot.qm') };
  spot.bytes = compress('assets/spot.obj', spot.file);
  const cubes = path.join(dir, 'cubes');
  fs.mkdirSync(cubes);
  cube = { file: path.join(cubes, 'cube.qm') };
  cube.bytes = compress('assets/quad/cc_cube.obj', cube.file);
  // Hostile files go beside the pages: qm serve checks its models at start.
  for (const f of ['qm-bad-magic.qm', 'qm-cut-in-header.qm', 'qm-cut-in-base.qm', 'qm-base-bit-flipped.qm', 'qm-bomb-level-11.qm', 'qm-bomb-level-12.qm', 'qm-version-7.qm']) {
    fs.copyFileSync(path.join(root, 'tests', 'corrupt', f), path.join(www, f));
  }
  fs.copyFileSync(spot.file, path.join(www, 'spot-static.qm'));
  colouredFile = { file: path.join(models, 'coloured.qm'), ...coloured(path.join(models, 'coloured.qm')) };
  texturedFile = path.join(models, 'textured_cube.qm');
  fs.copyFileSync(path.join(root, 'tests', 'data', 'textured_cube.qm'), texturedFile);
  const slowModels = path.join(dir, 'slow');
  fs.mkdirSync(slowModels);
  picoFile = path.join(slowModels, 'pico.qm');
  compress('assets/appearance/pico-neo3-left.glb', picoFile);
  // About 5 s for the whole spot file.
  throttled = await serve(models, { throttle: Math.max(8, Math.round(spot.bytes.length / 1024 / 5)), web: www });
  fast = await serve(cubes, { web: www });
  // The textured controller in about 4 s, for many refinements.
  slow = await serve(slowModels, { throttle: 3, web: www });
  b = await browser();
});

after(async () => {
  await b?.close();
  throttled?.stop();
  slow?.stop();
  fast?.stop();
  fs.rmSync(dir, { recursive: true, force: true });
});

test('a throttled .qm streams into one geometry and ends with the native mesh', { timeout: 120000 }, async () => {
  await page(throttled);
  const r = await b.page.evaluate(() => window.qmTest.stream('models/spot.qm', { level: 'finest' }));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  const first = r.updates[0];
  assert.ok(first.bytes < spot.bytes.length, `the first refinement after ${first.bytes} of ${spot.bytes.length} bytes`);
  assert.ok(r.updates.at(-1).t - first.t > 1500, `the first refinement ${r.updates.at(-1).t - first.t} ms before the last`);
  assert.ok(r.updates.length >= 5, `${r.updates.length} refinements`);
  assert.ok(r.updates.every((u) => u.same), 'one geometry, refined in place');
  const vertices = r.updates.map((u) => u.vertexCount);
  assert.deepEqual(vertices, vertices.slice().sort((x, y) => x - y), 'the vertex count never goes down');
  assert.equal(r.last.bytes, spot.bytes.length);
  assert.equal(r.last.complete, true);
  assertEqualsNative(spot.file, r, spot.bytes.length, r.last.level);
  assert.ok(await b.page.evaluate(() => window.qmTest.covered()) > 0.05, 'the mesh is drawn');
  assert.deepEqual(b.errors, []);
});

test('a prefix by maxBytes: the native mesh of that prefix, and no more sent', { timeout: 120000 }, async () => {
  await page(throttled);
  const maxBytes = 9000;
  throttled.log.length = 0;
  const r = await b.page.evaluate((n) => window.qmTest.stream('models/spot.qm', { maxBytes: n, level: 'finest' }), maxBytes);
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.equal(r.last.bytes, maxBytes);
  assert.equal(r.last.complete, false);
  const finest = r.last.level;
  assertEqualsNative(spot.file, r, maxBytes, finest);
  // Resume by Range to a longer prefix: the mesh of that prefix.
  const more = await b.page.evaluate(() => window.qmTest.resume({ maxBytes: 20000 }));
  assert.equal(more.ok, true, JSON.stringify(more.error));
  assert.equal(more.last.bytes, 20000);
  assertEqualsNative(spot.file, more, 20000, more.last.level);
  await new Promise((resolve) => setTimeout(resolve, 300)); // the server's last log lines
  assert.ok(logsRequests(throttled.log), `qm serve logs one line per request:\n${throttled.log.join('\n')}`);
  const sent = requests(throttled.log, '/models/spot.qm');
  assert.deepEqual(sent.map((s) => [s.range, s.status]), [['0-8999', 206], ['9000-19999', 206]], JSON.stringify(sent));
  assert.ok(sent[0].bytes <= maxBytes, `${sent[0].bytes} bytes sent for maxBytes ${maxBytes}`);
  assert.ok(sent[1].bytes <= 11000, `${sent[1].bytes} bytes sent on resume`);
  assert.deepEqual(b.errors, []);
});

test('maxError: growing ranges, stopped once the decoder says the goal is met', { timeout: 120000 }, async () => {
  await page(throttled);
  const probe = await b.page.evaluate(() => window.qmTest.decodeHere('models/spot.qm', { maxBytes: 20000 }));
  assert.equal(probe.ok, true, JSON.stringify(probe.error));
  assert.ok(Number.isFinite(probe.error) && probe.error > 0, `error estimate ${probe.error}`);
  throttled.log.length = 0;
  const r = await b.page.evaluate((maxError) => window.qmTest.stream('models/spot.qm', { maxError }, { geometry: false }), probe.error);
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.ok(r.last.error <= probe.error, `error ${r.last.error} for maxError ${probe.error}`);
  assert.ok(r.last.bytesUsed <= 40000, `${r.last.bytesUsed} bytes used`);
  await new Promise((resolve) => setTimeout(resolve, 300));
  const sent = requests(throttled.log, '/models/spot.qm');
  assert.ok(sent.length >= 2 && sent.every((s) => s.status === 206), JSON.stringify(sent));
  // Ranges follow one another and double what arrived.
  let at = 0;
  for (const s of sent) {
    const [first, last] = s.range.split('-').map(Number);
    assert.equal(first, at, JSON.stringify(sent));
    at = last + 1;
  }
  // The server sent at most one request's slack past the bytes used.
  const total = sent.reduce((n, s) => n + s.bytes, 0);
  const [first, last] = sent.at(-1).range.split('-').map(Number);
  assert.ok(total - r.last.bytesUsed <= last - first + 1, `${total} bytes sent, ${r.last.bytesUsed} used`);
  assert.ok(total < spot.bytes.length / 2);
});

test('bad files reject with a clear QMError and the page keeps running', { timeout: 120000 }, async () => {
  await page(fast);
  const cases = [
    ['qm-bad-magic.qm', 'not-qm', /magic/],
    ['qm-cut-in-header.qm', 'truncated', /header/],
    ['qm-cut-in-base.qm', 'truncated', /header or base mesh/],
    ['qm-base-bit-flipped.qm', 'corrupt', /base mesh is corrupt/],
    ['qm-version-7.qm', 'unsupported-version', /version 7/],
    ['qm-bomb-level-11.qm', 'memory', /memory/],
    ['qm-bomb-level-12.qm', 'limit', /above the limit/],
    ['no-such-file.qm', 'http', /404/],
  ];
  for (const [file, code, message] of cases) {
    const before = await b.page.evaluate(() => window.qmTest.frames());
    const r = await b.page.evaluate((url) => window.qmTest.load(url), file);
    assert.equal(r.ok, false, file);
    assert.equal(r.error.isQMError, true, `${file}: ${JSON.stringify(r.error)}`);
    assert.equal(r.error.isError, true);
    assert.equal(r.error.code, code, `${file}: ${r.error.message}`);
    assert.match(r.error.message, message, file);
    await b.page.evaluate(() => window.qmTest.nextFrames(3));
    const after = await b.page.evaluate(() => window.qmTest.frames());
    assert.ok(after > before, `${file}: the page still renders`);
  }
  // It still loads and draws a good file afterwards.
  const good = await b.page.evaluate(() => window.qmTest.load('models/cube.qm'));
  assert.equal(good.ok, true, JSON.stringify(good.error));
  assert.ok(await b.page.evaluate(() => window.qmTest.covered()) > 0.02);
  assert.deepEqual(b.errors.filter((e) => !/404/.test(e)), []);
});

test('an abort rejects with the signal reason; the page goes on', { timeout: 60000 }, async () => {
  await page(throttled);
  const r = await b.page.evaluate(() => window.qmTest.stream('models/spot.qm', {}, { abortAfterUpdates: 2, geometry: false }));
  assert.equal(r.ok, false);
  assert.equal(r.error.name, 'AbortError', JSON.stringify(r.error));
  assert.ok(r.updates.length >= 2);
  const frames = await b.page.evaluate(async () => {
    const n = window.qmTest.frames();
    await window.qmTest.nextFrames(3);
    return window.qmTest.frames() - n;
  });
  assert.ok(frames >= 3);
  // The aborted stream resumes from what it has.
  const more = await b.page.evaluate(() => window.qmTest.resume({ maxBytes: 20000, level: 'finest' }));
  assert.equal(more.ok, true, JSON.stringify(more.error));
  assert.equal(more.last.bytes, 20000);
  assertEqualsNative(spot.file, more, 20000, more.last.level);
  // A maxBytes inside the base mesh is 'truncated', and a larger one goes on.
  const cut = await b.page.evaluate(() => window.qmTest.stream('models/spot.qm', { maxBytes: 40 }, { geometry: false }));
  assert.equal(cut.ok, false);
  assert.equal(cut.error.code, 'truncated');
  assert.match(cut.error.message, /maxBytes/);
  const after = await b.page.evaluate(() => window.qmTest.resume({ maxBytes: 6000, level: 'finest' }));
  assert.equal(after.ok, true, JSON.stringify(after.error));
  assertEqualsNative(spot.file, after, 6000, after.last.level);
});

test('setDecoderPath fetches the wasm; loadAsync reports progress', { timeout: 60000 }, async () => {
  await page(fast);
  fast.log.length = 0;
  const r = await b.page.evaluate(() => window.qmTest.loadWithDecoderPath('libs/', 'models/cube.qm'));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.ok(r.vertexCount > 0);
  assert.ok(r.progress.length >= 1);
  assert.deepEqual(r.progress.at(-1), { loaded: cube.bytes.length, total: cube.bytes.length, lengthComputable: true });
  await new Promise((resolve) => setTimeout(resolve, 200));
  assert.equal(requests(fast.log, '/libs/qm_decoder_bg.wasm').length, 1, fast.log.join('\n'));
  const missing = await b.page.evaluate(() => window.qmTest.loadWithDecoderPath('nowhere/', 'models/cube.qm'));
  assert.equal(missing.ok, false);
  assert.equal(missing.error.code, 'http');
  assert.match(missing.error.message, /setDecoderPath/);
});

test('qm-decoder decodes on the main thread and in a module worker', { timeout: 60000 }, async () => {
  await page(fast);
  const here = await b.page.evaluate(() => window.qmTest.decodeHere('models/cube.qm', { level: 'finest' }));
  const there = await b.page.evaluate(() => window.qmTest.decodeInWorker('models/cube.qm', { level: 'finest' }));
  assert.equal(here.ok, true, JSON.stringify(here.error));
  assert.equal(there.ok, true, JSON.stringify(there.error));
  const n = reference(cube.file, cube.bytes.length, here.level);
  assert.equal(here.vertexCount, n.vertices);
  assert.deepEqual(there, here);
  const bad = await b.page.evaluate(() => window.qmTest.decodeInWorker('qm-bomb-level-11.qm'));
  assert.equal(bad.ok, false);
  assert.equal(bad.error.code, 'memory');
});

// `qm gltf` of spot.qm (or `source`) into the served folder, checked by Khronos's
// glTF validator: no errors, no warnings.
async function gltf(name, extra, source = spot.file) {
  const file = path.join(www, name);
  execFileSync(bins.qm, ['gltf', source, '-o', file, '--quiet', ...extra]);
  const bytes = new Uint8Array(fs.readFileSync(file));
  const external = { externalResourceFunction: (uri) => Promise.resolve(new Uint8Array(fs.readFileSync(path.join(www, uri)))) };
  const report = name.endsWith('.gltf')
    ? await validator.validateString(new TextDecoder().decode(bytes), external)
    : await validator.validateBytes(bytes, external);
  assert.equal(report.issues.numErrors + report.issues.numWarnings, 0, `${name}: ${JSON.stringify(report.issues.messages)}`);
  return bytes;
}

test('qm gltf: fallback with GLTFLoader, streamed with the plugin, the table sets the bytes', { timeout: 120000 }, async () => {
  const level = 2;
  const fallbackBytes = Math.min(spot.bytes.length, 6000);
  const fallback = ['--fallback-level', String(level), '--fallback-bytes', String(fallbackBytes)];
  await gltf('spot.glb', fallback);
  await gltf('spot-uri.glb', ['--uri', 'spot-static.qm', ...fallback]);
  await gltf('spot.gltf', ['--uri', 'spot-static.qm', ...fallback]);
  await page(fast);
  const plain = await b.page.evaluate(() => window.qmTest.gltf('spot.glb'));
  assert.equal(plain.ok, true, JSON.stringify(plain.error));
  assert.ok(plain.fallbackCovered > 0.05, 'the fallback is drawn');
  const n = reference(spot.file, fallbackBytes, level);
  assert.equal(plain.fallback.vertexCount, n.vertices);
  for (const file of ['spot.glb', 'spot-uri.glb', 'spot.gltf']) {
    const streamed = await b.page.evaluate((f) => window.qmTest.gltf(f, { plugin: true, options: { level: 'finest' } }), file);
    assert.equal(streamed.ok, true, `${file}: ${JSON.stringify(streamed.error)}`);
    assert.equal(streamed.fallback.vertexCount, n.vertices);
    assert.equal(streamed.final.sameGeometry, true);
    assert.equal(streamed.final.bytes, spot.bytes.length);
    assert.ok(streamed.updates.every((u) => u.bytes >= fallbackBytes), 'nothing coarser than the fallback is shown');
    assertEqualsNative(spot.file, streamed.final, spot.bytes.length, streamed.final.level);
    assert.ok(streamed.covered > 0.05);
  }
  // With maxError, the plugin asks for exactly the bytes of the first row of
  // the prefix table that meets it, and the decoder stops at the goal.
  await gltf('spot-table.glb', ['--uri', 'spot-static.qm']);
  const rows = JSON.parse(execFileSync(bins.qm, ['info', spot.file, '--levels', '--json'], { encoding: 'utf8' })).levels;
  const maxError = rows.find((r) => r.bytes >= 20000).error;
  const row = rows.find((r) => r.error <= maxError);
  fast.log.length = 0;
  const goal = await b.page.evaluate((e) => window.qmTest.gltf('spot-table.glb', { plugin: true, options: { maxError: e, requestInit: { cache: 'no-store' } } }), maxError);
  assert.equal(goal.ok, true, JSON.stringify(goal.error));
  assert.equal(goal.final.bytes, row.bytes);
  assert.ok(goal.final.error <= maxError, `error ${goal.final.error} for maxError ${maxError}`);
  assertEqualsNative(spot.file, goal.final, row.bytes, goal.final.level, ['--max-error', String(maxError)]);
  await new Promise((resolve) => setTimeout(resolve, 200));
  const sent = requests(fast.log, '/spot-static.qm');
  assert.deepEqual(sent.map((s) => [s.range, s.status, s.bytes]), [[`0-${row.bytes - 1}`, 206, row.bytes]], fast.log.join('\n'));
  // A goal the fallback meets already: nothing is fetched.
  const table = JSON.parse(new TextDecoder().decode(glbJson(fs.readFileSync(path.join(www, 'spot-table.glb')))));
  const fallbackError = table.meshes[0].primitives[0].extensions.QM_progressive_mesh.fallback.error;
  assert.ok(fallbackError > 0, `fallback error ${fallbackError}`);
  fast.log.length = 0;
  const met = await b.page.evaluate((e) => window.qmTest.gltf('spot-table.glb', { plugin: true, options: { maxError: e, requestInit: { cache: 'no-store' } } }), fallbackError);
  assert.equal(met.ok, true, JSON.stringify(met.error));
  assert.equal(met.final.bytes, 0);
  assert.equal(met.final.error, fallbackError);
  await new Promise((resolve) => setTimeout(resolve, 200));
  assert.deepEqual(requests(fast.log, '/spot-static.qm'), [], fast.log.join('\n'));
  assert.deepEqual(b.errors, []);
});

// The JSON chunk of a GLB.
function glbJson(bytes) {
  const length = bytes.readUInt32LE(12);
  return bytes.subarray(20, 20 + length);
}

test('a coloured file: colours at every refinement, a color attribute in step', { timeout: 120000 }, async () => {
  await page(throttled);
  const r = await b.page.evaluate(() => window.qmTest.colours('models/coloured.qm'));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.ok(r.decoded.length > 5, `${r.decoded.length} refinements`);
  for (const m of r.decoded) {
    assert.equal(m.colors.length, 3 * m.vertexCount, `one colour per vertex at ${m.bytesUsed} bytes`);
    const native = reference(colouredFile.file, m.bytesUsed, m.level);
    assert.equal(fnv1a(m.colors), native.colours, `the native decoder's colours at ${m.bytesUsed} bytes`);
  }
  assert.deepEqual(r.decoded.at(-1).colors, Array.from(colouredFile.rgb), 'the whole file: the input colours');
  assert.ok(r.updates.length > 1, `${r.updates.length} updates of the geometry`);
  for (const u of r.updates) {
    assert.deepEqual(u, { vertexCount: u.vertexCount, count: u.vertexCount, itemSize: 3, normalized: true, type: 'Uint16Array' });
  }
  assert.deepEqual(r.shownColors, Array.from(colouredFile.rgb), 'linear in the geometry, the input\'s sRGB on screen');
  assert.ok(r.covered > 0.05, 'the mesh is drawn');
  // Through qm gltf and the plugin: the material turns to vertex colours.
  await gltf('coloured.glb', ['--fallback-level', '2'], colouredFile.file);
  const g = await b.page.evaluate(() => window.qmTest.gltf('coloured.glb', { plugin: true, options: { level: 'finest' } }));
  assert.equal(g.ok, true, JSON.stringify(g.error));
  assert.equal(g.final.vertexCount, colouredFile.rgb.length / 3);
  assert.deepEqual(g.final.color, { count: g.final.vertexCount, type: 'Uint16Array', vertexColors: true, sharedMaterialChanged: false });
  assert.deepEqual(b.errors, []);
});

test('a textured file: a uv attribute and the texture, loaded and through qm gltf', { timeout: 120000 }, async () => {
  await page(throttled);
  const r = await b.page.evaluate(() => window.qmTest.textured('models/textured_cube.qm'));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  const native = reference(texturedFile, r.bytesUsed, r.level);
  assert.deepEqual(r.texture, { width: native.texture.width, height: native.texture.height, isDataTexture: true, colorSpace: 'srgb' });
  assert.equal(r.uv, r.position, 'one texture coordinate a vertex');
  assert.ok(r.position >= native.vertices, 'vertices split where base quads meet');
  assert.equal(r.color, false, 'the texture shows the colour');
  assert.ok(r.covered > 0.05, 'the mesh is drawn');
  assert.equal(r.shown, true, 'the material set on update shows the final texture');
  assert.equal(r.distinctMaps, 1, `one DataTexture for the stream, however its size changed: ${r.looks}`);
  assert.equal(r.looks.at(-1), 'texture');
  assert.equal(r.uploads, r.versions, 'one upload a texture the decoder made');
  // A textured controller: refinements that advance its geometry alone
  // upload nothing.
  await page(slow);
  const s = await b.page.evaluate(() => window.qmTest.textured('models/pico.qm'));
  assert.equal(s.ok, true, JSON.stringify(s.error));
  const textures = s.looks.filter((l) => l === 'texture').length;
  assert.ok(s.uploads === s.versions && s.versions < textures, `${s.uploads} uploads, ${s.versions} versions, ${textures} textured updates`);
  const ns = reference(picoFile, s.bytesUsed, s.level);
  assert.deepEqual([s.texture.width, s.texture.height, s.shown], [ns.texture.width, ns.texture.height, true]);
  // Through qm gltf and the plugin: the meshes' material shows the texture.
  await gltf('textured.glb', [], texturedFile);
  const g = await b.page.evaluate(() => window.qmTest.gltf('textured.glb', { plugin: true, options: { level: 'finest' } }));
  assert.equal(g.ok, true, JSON.stringify(g.error));
  assert.equal(g.final.map, true, 'the material\'s map is the texture');
  assert.equal(g.final.sharedMapChanged, false, 'a clone, not the shared material');
  assert.deepEqual(b.errors, []);
});
