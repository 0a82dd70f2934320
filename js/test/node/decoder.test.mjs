// qm-decoder in Node, as installed from its tarball (js/test/run.mjs copies
// this file into a clean folder where `npm install qm-decoder-*.tgz` ran):
// decodes equal the native decoder's at the same bytes and level (the
// checksum of `cargo run -p qm-wasm --example reference`), streaming in small
// chunks, the options, errors with codes, and every prefix of a small file.
//
// A coloured file (`cargo run -p qm-wasm --example coloured`) gives colours
// at every refinement, the native decoder's, and its input's at the end.
//
// Environment (set by run.mjs): QM_ROOT (the repository), QM_BIN (qm),
// QM_REFERENCE (the reference example), QM_COLOURED (the coloured example),
// QM_SCRATCH (a folder for files).

import assert from 'node:assert/strict';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { before, test } from 'node:test';
import { CODES, DEFAULT_MAX_MEMORY, QMError, StreamDecoder, decode, isReady, ready } from 'qm-decoder';

const root = process.env.QM_ROOT;
const scratch = process.env.QM_SCRATCH;
const corrupt = (name) => fs.readFileSync(path.join(root, 'tests', 'corrupt', name));

function compress(input, name) {
  const out = path.join(scratch, name);
  if (!fs.existsSync(out)) {
    execFileSync(process.env.QM_BIN, ['compress', path.join(root, input), '-o', out, '--quiet']);
  }
  return { file: out, bytes: new Uint8Array(fs.readFileSync(out)) };
}

function reference(file, bytes, level) {
  const args = [file, String(bytes)];
  if (level !== undefined) args.push(String(level));
  return JSON.parse(execFileSync(process.env.QM_REFERENCE, args, { encoding: 'utf8' }));
}

// FNV-1a (64 bit) of bytes, as the reference example prints `colours`.
function fnv1a(bytes) {
  let h = 0xcbf29ce484222325n;
  for (const b of bytes) h = ((h ^ BigInt(b)) * 0x100000001b3n) & 0xffffffffffffffffn;
  return h.toString(16).padStart(16, '0');
}

// The native decoder's answer for what a StreamDecoder shows now.
function assertNative(file, d, mesh, what) {
  const native = reference(file, mesh.bytesUsed, mesh.level);
  assert.deepEqual(
    { vertices: mesh.vertexCount, triangles: mesh.triangleCount, passes: mesh.passes, checksum: d.checksum() },
    { vertices: native.vertices, triangles: native.triangles, passes: native.passes, checksum: native.checksum },
    `${what}: ${mesh.bytesUsed} bytes, level ${mesh.level}`,
  );
}

let cube;
let spot;

before(async () => {
  await ready();
  cube = compress('assets/quad/cc_cube.obj', 'cube.qm');
  spot = compress('assets/spot.obj', 'spot.qm');
});

test('ready() loads the inlined module once', async () => {
  assert.equal(isReady(), true);
  const again = ready();
  assert.equal(again, ready());
  await again;
  assert.ok(CODES.includes('truncated'));
});

test('the wasm loads from bytes too (a fresh process)', () => {
  const require = createRequire(path.join(process.cwd(), 'package.json'));
  const wasm = require.resolve('qm-decoder/qm_decoder_bg.wasm');
  const script = `
    import fs from 'node:fs';
    import { ready, decode } from 'qm-decoder';
    await ready({ wasm: fs.readFileSync(${JSON.stringify(wasm)}) });
    const m = await decode(fs.readFileSync(${JSON.stringify(cube.file)}));
    console.log(JSON.stringify({ v: m.vertexCount, complete: m.complete }));
  `;
  const out = execFileSync(process.execPath, ['--input-type=module', '-e', script], { encoding: 'utf8' });
  const r = JSON.parse(out);
  assert.ok(r.v > 0);
  assert.equal(r.complete, true);
});

test('decode() of the whole file equals the native decoder', async () => {
  for (const { file, bytes } of [cube, spot]) {
    const m = await decode(bytes, { level: 'finest' });
    assert.equal(m.complete, true);
    assert.equal(m.passes, m.totalPasses);
    assert.equal(m.level, m.finestLevel);
    assert.equal(m.positions.length, 3 * m.vertexCount);
    assert.equal(m.normals.length, 3 * m.vertexCount);
    assert.equal(m.indices.length, 3 * m.triangleCount);
    assert.ok(m.positions instanceof Float32Array && m.normals instanceof Float32Array && m.indices instanceof Uint32Array);
    const d = new StreamDecoder({ level: 'finest' });
    d.push(bytes);
    const again = d.end();
    assertNative(file, d, again, path.basename(file));
    assert.deepEqual(again.positions, m.positions);
    d.dispose();
  }
});

test('decode() at a prefix and a level equals the native decoder', async () => {
  const { file, bytes } = spot;
  const probe = new StreamDecoder();
  probe.push(bytes);
  const start = probe.streamStart;
  const finest = probe.finestLevel;
  probe.dispose();
  for (const n of [start, start + 1, start + 1000, Math.floor(bytes.length / 3), bytes.length - 1]) {
    for (const level of [0, 2, finest]) {
      const d = new StreamDecoder({ maxBytes: n, level });
      d.push(bytes);
      const m = d.refine();
      assert.equal(m.level, level);
      assert.equal(m.bytesReceived, n);
      assertNative(file, d, m, 'prefix');
      d.dispose();
    }
  }
});

test('streaming in small chunks refines and ends with the native mesh', () => {
  const { file, bytes } = spot;
  const d = new StreamDecoder({ level: 'finest' });
  let shown = 0;
  let passes = 0;
  let readyAt = null;
  for (let at = 0; at < bytes.length; at += 509) {
    const ready = d.push(bytes.subarray(at, at + 509));
    if (!ready) {
      assert.equal(d.refine(), null, 'no mesh before the base mesh');
      continue;
    }
    readyAt ??= d.bytesReceived;
    const m = d.refine();
    assert.equal(d.refine(), null, 'nothing new without new bytes');
    if (!m) continue;
    assert.ok(m.passes >= passes, 'passes never go down');
    passes = m.passes;
    if (shown++ % 40 === 0) assertNative(file, d, m, 'chunked');
  }
  assert.ok(readyAt >= d.streamStart && readyAt < d.streamStart + 509);
  const last = d.end();
  assert.equal(last, null, 'end() after the last refine has nothing new');
  assert.equal(d.wantsMore, false);
  d.setOptions({ level: 'finest' });
  const final = d.refine();
  assert.equal(final.complete, true);
  assertNative(file, d, final, 'final');
  assert.ok(shown > 20, `${shown} refinements`);
  d.dispose();
  assert.throws(() => d.push(bytes), /disposed/);
});

test('every prefix of a small file decodes or says it is truncated', async () => {
  const { file, bytes } = cube;
  let passes = 0;
  let start = null;
  for (let n = 1; n <= bytes.length; n++) {
    const prefix = bytes.subarray(0, n);
    let m;
    try {
      m = await decode(prefix, { level: 'finest' });
    } catch (e) {
      assert.ok(e instanceof QMError, String(e));
      assert.equal(e.code, 'truncated', `${n} bytes: ${e.message}`);
      assert.equal(start, null, `${n} bytes: truncated after a prefix decoded`);
      continue;
    }
    start ??= n;
    assert.ok(m.passes >= passes, `${n} bytes: passes went down`);
    passes = m.passes;
    if (n % 211 === 0 || n === start || n === bytes.length) {
      const d = new StreamDecoder({ level: 'finest' });
      d.push(prefix);
      assertNative(file, d, d.refine(), 'every prefix');
      d.dispose();
    }
  }
  assert.ok(start > 4 && start < bytes.length);
});

test('options: maxBytes, level, maxTriangles, maxError', async () => {
  const { bytes } = spot;
  const cut = await decode(bytes, { maxBytes: 9000, level: 'finest' });
  const same = await decode(bytes.subarray(0, 9000), { level: 'finest' });
  assert.equal(cut.bytesReceived, 9000);
  assert.deepEqual(cut.positions, same.positions);
  assert.equal(cut.complete, false);

  const d = new StreamDecoder({ maxBytes: 9000 });
  assert.equal(d.push(bytes.subarray(0, 5000)), true);
  d.push(bytes.subarray(5000));
  assert.equal(d.bytesReceived, 9000, 'bytes past maxBytes are ignored');
  assert.equal(d.wantsMore, false);
  d.setOptions({ maxBytes: 12000 });
  assert.equal(d.wantsMore, true, 'a larger maxBytes wants more again');
  d.dispose();

  const coarse = await decode(bytes, { level: 0 });
  assert.equal(coarse.level, 0);
  const probe = new StreamDecoder();
  probe.push(bytes);
  assert.equal(coarse.vertexCount, probe.vertexCountAt(0));
  probe.dispose();

  await assert.rejects(decode(bytes, { level: 'fine' }), TypeError);
  await assert.rejects(decode(bytes, { maxBytes: -1 }), TypeError);
  await assert.rejects(decode('not bytes'), TypeError);

  const limited = await decode(bytes, { maxTriangles: 3000 });
  const auto = await decode(bytes);
  assert.ok(limited.triangleCount <= 3000, `${limited.triangleCount} triangles`);
  assert.ok(auto.level <= auto.finestLevel);
  assert.ok(auto.error >= 0 && auto.psnr > 0);
  // maxError: the decoder stops at a prefix whose estimate meets it.
  const early = await decode(bytes, { maxBytes: 9000 });
  assert.ok(early.error > 0, `error ${early.error} at 9000 bytes`);
  const goal = await decode(bytes, { maxError: early.error });
  assert.ok(goal.error <= early.error, `error ${goal.error} for maxError ${early.error}`);
  assert.ok(goal.bytesUsed < bytes.length, `${goal.bytesUsed} bytes used`);
  const s = new StreamDecoder({ maxError: early.error });
  for (let at = 0; at < bytes.length && s.wantsMore; at += 1000) {
    if (s.push(bytes.subarray(at, at + 1000))) s.refine();
  }
  assert.equal(s.wantsMore, false, 'the goal is met before the end');
  assert.ok(s.bytesReceived < bytes.length);
  s.setOptions({ maxError: 0 });
  assert.equal(s.wantsMore, true, 'a smaller goal wants more');
  s.dispose();
});

test('bad input rejects with a QMError carrying a code and a clear message', async () => {
  const cases = [
    ['not-qm', new TextEncoder().encode('solid cube\nfacet normal 0 0 1\n')],
    ['not-qm', corrupt('qm-bad-magic.qm')],
    ['unsupported-version', corrupt('qm-version-7.qm')],
    ['truncated', corrupt('qm-cut-in-header.qm')],
    ['truncated', corrupt('qm-cut-in-base.qm')],
    ['truncated', corrupt('qm-empty.qm')],
    ['corrupt', corrupt('qm-base-bit-flipped.qm')],
    ['corrupt', corrupt('qm-header-bit-flipped.qm')],
    ['limit', corrupt('qm-bomb-level-12.qm')],
    ['memory', corrupt('qm-bomb-level-11.qm')],
    ['memory', corrupt('qm-bomb-base-faces.qm')],
  ];
  for (const [code, bytes] of cases) {
    const e = await decode(bytes).then(() => null, (x) => x);
    assert.ok(e instanceof QMError, `${code}: ${e}`);
    assert.ok(e instanceof Error);
    assert.equal(e.name, 'QMError');
    assert.equal(e.code, code, `expected ${code}: ${e.message}`);
    assert.ok(e.message.length > 10, e.message);
  }
  // The limit the package names is the one the decoder holds to.
  const bomb = await decode(corrupt('qm-bomb-level-11.qm')).then(() => null, (x) => x);
  assert.ok(bomb.message.includes(`above the limit of ${DEFAULT_MAX_MEMORY / 2 ** 20} MiB`), bomb.message);
  // The memory limit is an option.
  const e = await decode(spot.bytes, { maxMemory: 1 << 20 }).then(() => null, (x) => x);
  assert.equal(e?.code, 'memory', String(e));
  assert.match(e.message, /memory/);
  // The decoder goes on working after errors.
  const m = await decode(cube.bytes);
  assert.ok(m.vertexCount > 0);
});

test('a streaming decoder throws as soon as the bytes show the problem', () => {
  const d = new StreamDecoder();
  assert.equal(d.push(new Uint8Array([0x89])), false);
  assert.equal(d.wantsMore, true);
  assert.throws(() => d.push(new TextEncoder().encode('PNG\r\n\x1a\n0000000000')), (e) => e instanceof QMError && e.code === 'not-qm');
  d.dispose();
  const cut = corrupt('qm-cut-in-base.qm');
  const s = new StreamDecoder();
  assert.equal(s.push(cut), false);
  assert.throws(() => s.end(), (e) => e.code === 'truncated' && /header or base mesh/.test(e.message));
  s.dispose();
  assert.throws(() => new StreamDecoder({ maxError: 'small' }), TypeError);
});

test('a coloured file: colours at every refinement, the input\'s at the end', async () => {
  const file = path.join(scratch, 'coloured.qm');
  execFileSync(process.env.QM_COLOURED, [file]);
  const bytes = new Uint8Array(fs.readFileSync(file));
  const rgb = new Uint8Array(fs.readFileSync(path.join(scratch, 'coloured.rgb')));
  for (const level of ['auto', 'finest']) {
    const d = new StreamDecoder({ level });
    assert.equal(d.hasColors, false, 'not known before the header');
    let shown = 0;
    for (let at = 0; at < bytes.length; at += 401) {
      if (!d.push(bytes.subarray(at, at + 401))) continue;
      assert.equal(d.hasColors, true);
      const m = d.refine();
      if (!m) continue;
      shown++;
      assert.ok(m.colors instanceof Uint8Array);
      assert.equal(m.colors.length, 3 * m.vertexCount, `${level}: one colour per vertex at ${m.bytesUsed} bytes`);
      const native = reference(file, m.bytesUsed, m.level);
      assert.equal(fnv1a(m.colors), native.colours, `${level}: the native decoder's colours at ${m.bytesUsed} bytes`);
    }
    assert.ok(shown > 5, `${level}: ${shown} refinements`);
    d.end();
    d.dispose();
  }
  const m = await decode(bytes, { level: 'finest' });
  assert.equal(m.complete, true);
  assert.deepEqual(m.colors, rgb, 'the whole file gives the input colours exactly');
  // A file without colours has none.
  assert.equal((await decode(cube.bytes)).colors, null);
});

test('a file with colour finer than its geometry: a texture and its coordinates', async () => {
  const file = path.join(root, 'tests', 'data', 'textured_cube.qm');
  const bytes = new Uint8Array(fs.readFileSync(file));
  const d = new StreamDecoder();
  let shown = 0;
  for (let at = 0; at < bytes.length; at += 997) {
    if (!d.push(bytes.subarray(at, at + 997))) continue;
    const m = d.refine();
    if (!m) continue;
    const native = reference(file, m.bytesUsed, m.level);
    if (!native.texture) {
      assert.equal(m.texture, null, `no texture at ${m.bytesUsed} bytes`);
      continue;
    }
    shown++;
    const { width, height, data } = m.texture;
    assert.deepEqual([width, height], [native.texture.width, native.texture.height]);
    const rgb = data.filter((_, i) => i % 4 !== 3);
    assert.equal(fnv1a(rgb), native.texture.checksum, `the native decoder's texture at ${m.bytesUsed} bytes`);

    // The textured triangles are the mesh's, over split vertices with
    // coordinates on texel centres inside the image.
    const t = m.textured;
    assert.equal(t.indices.length, m.indices.length);
    assert.ok(t.indices.every((v, k) => t.vertices[v] === m.indices[k]));
    assert.equal(t.uvs.length, 2 * t.vertices.length);
    for (let k = 0; k < t.uvs.length; k += 2) {
      const x = t.uvs[k] * width - 0.5;
      const y = t.uvs[k + 1] * height - 0.5;
      assert.ok(Math.abs(x - Math.round(x)) < 1e-2 && Math.abs(y - Math.round(y)) < 1e-2);
      assert.ok(x > 0 && x < width - 1 && y > 0 && y < height - 1);
    }
  }
  assert.ok(shown > 0, 'a texture once the colour reached finer levels');
  d.end();
  d.dispose();
  assert.equal((await decode(cube.bytes)).texture, null);
});

test('a texture keeps its version while refinements advance the geometry alone', async () => {
  // A textured controller (its colour two levels finer than its own
  // triangles): its geometry's bytes and its colour's alternate, so some
  // refinements advance the geometry alone.
  const { file, bytes } = compress('assets/appearance/pico-neo3-left.glb', 'pico.qm');
  // A twin fed the same bytes: the same textures, versions of its own.
  const [d, twin] = [new StreamDecoder(), new StreamDecoder()];
  let last = null;
  let [shown, kept] = [0, 0];
  for (let at = 0; at < bytes.length; at += 127) {
    const chunk = bytes.subarray(at, at + 127);
    twin.push(chunk);
    if (!d.push(chunk)) continue;
    const m = d.refine();
    const t = twin.refine();
    if (!m?.texture) continue;
    shown++;
    assert.notEqual(t.texture.version, m.texture.version, `another decoder's version at ${m.bytesUsed} bytes`);
    const native = reference(file, m.bytesUsed, m.level);
    const rgb = m.texture.data.filter((_, i) => i % 4 !== 3);
    assert.equal(fnv1a(rgb), native.texture.checksum, `the native decoder's texture at ${m.bytesUsed} bytes`);
    if (last?.version === m.texture.version) {
      // A kept version is the last mesh's objects again, not copies, and
      // what a decoder making them anew makes.
      assert.ok(m.texture === last.objects[0] && m.textured === last.objects[1], `the same objects at ${m.bytesUsed} bytes`);
      const fresh = new StreamDecoder();
      fresh.push(bytes.subarray(0, m.bytesUsed));
      const f = fresh.end();
      assert.deepEqual([f.textured.vertices, f.textured.uvs, f.textured.indices], [m.textured.vertices, m.textured.uvs, m.textured.indices], `fresh triangles at ${m.bytesUsed} bytes`);
      fresh.dispose();
      kept++;
    }
    last = { version: m.texture.version, objects: [m.texture, m.textured] };
  }
  assert.ok(kept > 0 && kept < shown, `${kept} of ${shown} textures kept`);
  d.dispose();
  twin.dispose();
});
