// three-qm-loader against servers that do Range badly or not at all, in
// headless Chromium: a small Node server (in this process, on 127.0.0.1)
// serves the bundled test page and a .qm in several ways:
//   /ignore/  ignores Range and sends the whole file (200), paced: the loader
//             must read the body up to maxBytes and cancel it;
//   /nolength/ ignores Range, sends no Content-Length: no total is reported;
//   /star/    answers Range with `Content-Range: bytes A-B/*` (no length),
//             for a file cut to 64 KiB: the loader learns the end from a 416;
//   /changed/ answers Range with a new ETag each time: resuming must fail.
//
// Environment: QM_WWW, the bundled pages (set by run.mjs).

import assert from 'node:assert/strict';
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import { after, before, test } from 'node:test';
import { browser, compress, reference, scratch } from '../harness.mjs';

const www = process.env.QM_WWW;
const types = { '.html': 'text/html', '.js': 'text/javascript', '.wasm': 'application/wasm' };

let dir;
let file;
let bytes;
let server;
let origin;
let b;
const sent = []; // { mode, range, status, bytes } per request for the .qm

const sleep = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

// Writes `body` in 2 KB pieces every 10 ms (200 KB/s), counting what the socket took.
async function paced(res, body, record) {
  for (let at = 0; at < body.length && !res.destroyed; at += 2048) {
    const piece = body.subarray(at, at + 2048);
    const ok = res.write(piece);
    record.bytes += piece.length;
    if (!ok) await new Promise((resolve) => res.once('drain', resolve));
    await sleep(10);
  }
  res.end();
}

function handle(req, res) {
  const url = new URL(req.url, 'http://x');
  const [, mode, name] = url.pathname.split('/');
  if (!name || !name.endsWith('.qm')) {
    const f = path.join(www, path.basename(url.pathname) || 'loader.html');
    if (!fs.existsSync(f)) {
      res.writeHead(404).end();
      return;
    }
    res.writeHead(200, { 'Content-Type': types[path.extname(f)] ?? 'application/octet-stream' });
    res.end(fs.readFileSync(f));
    return;
  }
  const body = name === 'cut.qm' ? bytes.subarray(0, 65536) : bytes;
  const range = /^bytes=(\d+)-(\d*)$/.exec(req.headers.range ?? '');
  const record = { mode, range: req.headers.range ?? '-', status: 0, bytes: 0 };
  sent.push(record);
  res.setHeader('Content-Type', 'application/octet-stream');
  if (mode === 'ignore' || mode === 'nolength' || !range) {
    record.status = 200;
    if (mode !== 'nolength') res.setHeader('Content-Length', body.length);
    res.writeHead(200);
    paced(res, body, record);
    return;
  }
  const start = Number(range[1]);
  const end = Math.min(range[2] === '' ? body.length - 1 : Number(range[2]), body.length - 1);
  if (start >= body.length) {
    record.status = 416;
    res.writeHead(416, { 'Content-Range': mode === 'star' ? 'bytes */*' : `bytes */${body.length}` }).end();
    return;
  }
  record.status = 206;
  const tag = mode === 'changed' ? `"v${sent.length}"` : '"same"';
  res.writeHead(206, {
    'Content-Range': `bytes ${start}-${end}/${mode === 'star' ? '*' : body.length}`,
    'Content-Length': end - start + 1,
    ETag: tag,
  });
  paced(res, body.subarray(start, end + 1), record);
}

before(async () => {
  dir = scratch('http');
  file = path.join(dir, 'spot.qm');
  bytes = compress('assets/spot.obj', file);
  server = http.createServer(handle);
  await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
  origin = `http://127.0.0.1:${server.address().port}`;
  b = await browser();
  await b.page.goto(`${origin}/loader.html`);
  await b.page.waitForFunction(() => window.qmTest && window.qmTest.frames() > 2);
});

after(async () => {
  await b?.close();
  server?.closeAllConnections?.();
  server?.close();
  fs.rmSync(dir, { recursive: true, force: true });
});

test('a server that ignores Range: the body is cancelled after maxBytes', { timeout: 60000 }, async () => {
  sent.length = 0;
  const r = await b.page.evaluate(() => window.qmTest.stream('/ignore/spot.qm', { maxBytes: 9000, level: 'finest' }, { geometry: false }));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.equal(r.last.bytes, 9000);
  assert.equal(r.last.total, bytes.length, 'the length from Content-Length of the 200');
  await sleep(300);
  assert.equal(sent.length, 1);
  assert.equal(sent[0].status, 200);
  assert.ok(sent[0].bytes < 40000, `the server wrote ${sent[0].bytes} of ${bytes.length} bytes before the client cancelled`);
  const n = reference(file, 9000, r.last.level);
  assert.equal(r.last.vertexCount, n.vertices);
});

test('resuming on a server that ignores Range skips what arrived', { timeout: 60000 }, async () => {
  await b.page.evaluate(() => window.qmTest.stream('/ignore/spot.qm', { maxBytes: 5000, level: 'finest' }, { geometry: false }));
  const more = await b.page.evaluate(() => window.qmTest.resume({ maxBytes: 15000 }, { geometry: false }));
  assert.equal(more.ok, true, JSON.stringify(more.error));
  assert.equal(more.last.bytes, 15000);
  const n = reference(file, 15000, more.last.level);
  assert.equal(more.last.vertexCount, n.vertices);
});

test('no length sent: none is reported, the whole file still decodes', { timeout: 60000 }, async () => {
  const r = await b.page.evaluate(() => window.qmTest.stream('/nolength/spot.qm', { level: 'finest' }, { geometry: false }));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.ok(r.updates.every((u) => u.total === null), 'no total without Content-Length or Content-Range');
  assert.equal(r.last.bytes, bytes.length);
  assert.equal(r.last.complete, true);
});

test('growing ranges without a length end at the 416', { timeout: 60000 }, async () => {
  sent.length = 0;
  // An error goal no prefix meets: the loader asks for 16 KiB, then doubles
  // what it has, and learns from the 416 that the 65,536-byte file ended.
  const r = await b.page.evaluate(() => window.qmTest.stream('/star/cut.qm', { maxError: 1e-30, level: 'finest' }, { geometry: false }));
  assert.equal(r.ok, true, JSON.stringify(r.error));
  assert.deepEqual(sent.map((s) => [s.range, s.status]), [
    ['bytes=0-16383', 206],
    ['bytes=16384-32767', 206],
    ['bytes=32768-65535', 206],
    ['bytes=65536-131071', 416],
  ]);
  assert.equal(r.last.bytes, 65536);
  assert.equal(r.last.total, null);
  const n = reference(file, 65536, r.last.level);
  assert.equal(r.last.vertexCount, n.vertices);
});

test('a file that changes between requests fails the resume', { timeout: 60000 }, async () => {
  const first = await b.page.evaluate(() => window.qmTest.stream('/changed/spot.qm', { maxBytes: 4000 }, { geometry: false }));
  assert.equal(first.ok, true, JSON.stringify(first.error));
  const more = await b.page.evaluate(() => window.qmTest.resume({ maxBytes: 9000 }, { geometry: false }));
  assert.equal(more.ok, false);
  assert.equal(more.error.code, 'http');
  assert.match(more.error.message, /changed/);
});
