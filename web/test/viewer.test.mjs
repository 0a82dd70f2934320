// The viewer in a real browser: headless Chromium (Debian's package, driven
// by playwright-core) streams spot.qm from `qm serve --throttle`, and at
// three moments (the first picture, two passes later, the end) the
// test takes a screenshot and checks that
//   - bytes and passes grow, the vertex count never falls, the mesh
//     changes and covers pixels,
//   - the mesh shown equals what the native one-shot decoder makes of the
//     same bytes at the same level (checksum of quantized values and
//     triangles),
//   - the final mesh equals `qm decompress` of the whole file: same vertex
//     positions (rounded to f32) and the same quads;
// and a file with colours (the qm-wasm example `coloured`) shows them.
// Screenshots go to target/web-test/; with QM_UPDATE_DOCS=1 also to
// docs/viewer/.
//
// Needs release builds of qm and the qm-wasm examples and a built viewer:
// `.ci/web` does it all.

import assert from 'node:assert/strict';
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { test } from 'node:test';
import { bins, browser, compress, reference, root, scratch, serve } from './harness.mjs';

const shots = path.join(root, 'target', 'web-test');
const docs = path.join(root, 'docs', 'viewer');

// With the picture held still (the wait that led here paused the viewer in
// the frame it saw what it waited for): reads the state, the mesh's checksum
// and the pixels, takes a screenshot, lets the viewer go on.
async function moment(page, name) {
  const snap = await page.evaluate(() => {
    const v = window.qmViewer;
    const { bytes, level, passes, vertices, triangles, finestLevel, totalPasses, done, error } = v.state;
    return { bytes, level, passes, vertices, triangles, finestLevel, totalPasses, done, error, checksum: v.checksum(), pixels: v.capture() };
  });
  fs.mkdirSync(shots, { recursive: true });
  const file = path.join(shots, `${name}.png`);
  await page.screenshot({ path: file });
  if (process.env.QM_UPDATE_DOCS === '1') {
    fs.mkdirSync(docs, { recursive: true });
    fs.copyFileSync(file, path.join(docs, `${name}.png`));
  }
  await page.evaluate(() => window.qmViewer.pause(false));
  return snap;
}

function coveredFraction(p) {
  const background = p.grey[0]; // a corner
  return p.grey.filter((g) => Math.abs(g - background) > 8).length / p.grey.length;
}

function readObj(file) {
  const positions = [];
  const quads = [];
  for (const line of fs.readFileSync(file, 'utf8').split('\n')) {
    const f = line.trim().split(/\s+/);
    if (f[0] === 'v') positions.push(f.slice(1, 4).map(Number));
    if (f[0] === 'f') quads.push(f.slice(1).map((c) => Number(c.split('/')[0]) - 1));
  }
  return { positions, quads };
}

test('qm serve refuses a file that is not .qm with one line naming it', () => {
  const dir = scratch('bad');
  const bad = path.join(dir, 'bad.qm');
  fs.writeFileSync(bad, 'not a qm file');
  const r = spawnSync(bins.qm, ['serve', bad, '--port', '0'], { encoding: 'utf8', timeout: 10000 });
  assert.equal(r.status, 1);
  const lines = r.stderr.trim().split('\n');
  assert.equal(lines.length, 1, r.stderr);
  assert.match(lines[0], /^error: .*bad\.qm: /);
  assert.doesNotMatch(r.stderr, /panicked/);
  fs.rmSync(dir, { recursive: true, force: true });
});

test('the viewer streams spot.qm throttled, refines, and ends with the native mesh', { timeout: 180000 }, async () => {
  const dir = scratch('spot');
  const file = path.join(dir, 'spot.qm');
  const bytes = compress('assets/spot.obj', file);
  // About 6 s for the whole file.
  const throttle = Math.max(4, Math.round(bytes.length / 1024 / 6));
  const server = await serve(file, { throttle });
  const b = await browser();
  try {
    await b.page.goto(server.url);
    const ok = (expr) => b.page.waitForFunction(expr, null, { timeout: 60000 });

    await ok(() => {
      const v = window.qmViewer;
      const seen = v && (v.state.vertices > 0 || v.state.error);
      if (seen) v.pause(true);
      return seen;
    });
    const first = await moment(b.page, 'stage-1');
    assert.equal(first.error, null);
    assert.ok(first.bytes < bytes.length, 'the first picture comes before the whole file');

    // Two passes later. With the decoder choosing the level the bytes
    // support, spot reaches its finest level on about its first 1.2 KB,
    // so the first picture may already be at the finest level: what
    // refines from there on is the detail, not the vertex count.
    await b.page.waitForFunction(
      (p) => {
        const v = window.qmViewer;
        const seen = v.state.passes >= p + 2;
        if (seen) v.pause(true);
        return seen;
      },
      first.passes,
      { timeout: 60000, polling: 'raf' },
    );
    const middle = await moment(b.page, 'stage-2');
    assert.ok(middle.bytes < bytes.length);

    await ok(() => {
      const v = window.qmViewer;
      if (v.state.done) v.pause(true);
      return v.state.done;
    });
    const last = await moment(b.page, 'stage-3');
    assert.equal(last.error, null);
    assert.equal(last.bytes, bytes.length);
    assert.equal(last.level, last.finestLevel);
    assert.equal(last.passes, last.totalPasses);

    // Bytes and passes grow, the vertex count never falls, the picture
    // changes, the mesh covers pixels.
    assert.ok(first.bytes < middle.bytes && first.passes < middle.passes, `passes ${first.passes}, ${middle.passes}`);
    assert.ok(first.vertices <= middle.vertices && middle.vertices <= last.vertices,
      `vertices ${first.vertices}, ${middle.vertices}, ${last.vertices}`);
    for (const m of [first, middle, last]) {
      assert.ok(coveredFraction(m.pixels) > 0.05, `the mesh covers ${coveredFraction(m.pixels)} of the picture`);
    }
    // The mesh changes at each moment (the picture may barely: the first
    // one can come after a dozen kilobytes, at 77 dB).
    assert.ok(first.checksum !== middle.checksum && middle.checksum !== last.checksum, 'the mesh changes');

    // Each mesh shown is the native decoder's for the same bytes and level.
    for (const m of [first, middle, last]) {
      const native = reference(file, m.bytes, m.level);
      assert.deepEqual(
        { vertices: m.vertices, triangles: m.triangles, passes: m.passes, checksum: m.checksum },
        { vertices: native.vertices, triangles: native.triangles, passes: native.passes, checksum: native.checksum },
        `at ${m.bytes} bytes, level ${m.level}`,
      );
    }

    // The final mesh is `qm decompress` of the whole file.
    const obj = path.join(dir, 'full.obj');
    execFileSync(bins.qm, ['decompress', file, '-o', obj, '--quiet']);
    const expected = readObj(obj);
    const positions = await b.page.evaluate(() => window.qmViewer.positions());
    const indices = await b.page.evaluate(() => window.qmViewer.indices());
    assert.equal(positions.length, 3 * expected.positions.length);
    let mismatched = 0;
    expected.positions.forEach((p, i) => {
      for (let d = 0; d < 3; d++) {
        if (Math.fround(p[d]) !== positions[3 * i + d]) mismatched++;
      }
    });
    assert.equal(mismatched, 0, 'positions equal qm decompress (as f32)');
    assert.equal(indices.length, 6 * expected.quads.length);
    expected.quads.forEach(([a, b2, c, d], k) => {
      const t = indices.slice(6 * k, 6 * k + 6);
      assert.deepEqual(t, [a, b2, c, a, c, d]);
    });
    assert.deepEqual(b.errors, []);
  } finally {
    await b.close();
    server.stop();
    fs.rmSync(dir, { recursive: true, force: true });
  }
});

test('?throttle paces a fast download in the page and ?level fixes the level', { timeout: 120000 }, async () => {
  const dir = scratch('cube');
  const file = path.join(dir, 'cube.qm');
  const bytes = compress('assets/quad/cc_cube.obj', file);
  const server = await serve(file);
  const b = await browser({ width: 480, height: 300 });
  try {
    // 4 KB/s: the 6.6 KB file takes about 1.6 s, in pieces of 205 bytes.
    await b.page.goto(`${server.url}?file=models/cube.qm&throttle=4&level=3`);
    await b.page.waitForFunction(() => window.qmViewer?.state.done, null, { timeout: 60000 });
    const s = await b.page.evaluate(() => {
      const { bytes, level, vertices, history, error, ttfpMs, ttfpBytes, fetchMs } = window.qmViewer.state;
      return { bytes, level, vertices, history, error, ttfpMs, ttfpBytes, fetchMs, checksum: window.qmViewer.checksum() };
    });
    assert.equal(s.error, null);
    assert.equal(s.bytes, bytes.length);
    assert.equal(s.level, 3);
    assert.ok(s.history.length >= 5, `${s.history.length} refinements`);
    assert.ok(s.ttfpBytes < bytes.length / 2, `first picture after ${s.ttfpBytes} bytes`);
    // Pacing: the last refinement comes at least 1.2 s after the request.
    assert.ok(s.history.at(-1).t - s.fetchMs >= 1200, `done ${s.history.at(-1).t - s.fetchMs} ms after the request`);
    const native = reference(file, bytes.length, 3);
    assert.equal(s.vertices, native.vertices);
    assert.equal(s.checksum, native.checksum);
    const passes = s.history.map((h) => h.passes);
    assert.deepEqual(passes, passes.slice().sort((x, y) => x - y), 'passes never go down');
    assert.deepEqual(b.errors, []);
  } finally {
    await b.close();
    server.stop();
    fs.rmSync(dir, { recursive: true, force: true });
  }
});

test('a file with colours shows them', { timeout: 120000 }, async () => {
  const dir = scratch('coloured');
  const file = path.join(dir, 'coloured.qm');
  execFileSync(bins.coloured, [file]);
  const server = await serve(file);
  const b = await browser({ width: 320, height: 240 });
  try {
    await b.page.goto(server.url);
    await b.page.waitForFunction(() => window.qmViewer?.state.done, null, { timeout: 60000 });
    await b.page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
    // Strongly saturated pixels: the sphere's colour bands, where the
    // viewer's own tan (saturation 0.33) has none.
    const { rgba } = await b.page.evaluate(() => window.qmViewer.capture(96, true));
    let n = 0;
    for (let i = 0; i < rgba.length; i += 4) {
      const max = Math.max(rgba[i], rgba[i + 1], rgba[i + 2]);
      if (max > 60 && max - Math.min(rgba[i], rgba[i + 1], rgba[i + 2]) > 0.6 * max) n++;
    }
    const saturated = n / (rgba.length / 4);
    assert.ok(saturated > 0.1, `${saturated} of the picture in saturated colours`);
    assert.deepEqual(b.errors, []);
  } finally {
    await b.close();
    server.stop();
    fs.rmSync(dir, { recursive: true, force: true });
  }
});
