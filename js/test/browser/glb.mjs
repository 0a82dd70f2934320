// A small GLB with the extension QM_progressive_mesh, made by hand for the
// browser test: one primitive whose accessors hold a fallback (a prefix of
// the .qm decoded at one level: positions and the quads split along their
// first diagonal) and whose extension points at the .qm, in a bufferView of
// the GLB or by `uri`.

import fs from 'node:fs';

const pad4 = (n) => (n + 3) & ~3;

/**
 * @param {string} file the .glb to write
 * @param {{ qm: Uint8Array, uri?: string, fallback: { positions: number[], quads: number[][] },
 *           fallbackBytes: number, fallbackLevel: number, streamStart?: number, finestLevel?: number,
 *           levels?: object[] }} o
 */
export function writeGlb(file, o) {
  const positions = Float32Array.from(o.fallback.positions);
  const indices = Uint32Array.from(o.fallback.quads.flatMap(([a, b, c, d]) => [a, b, c, a, c, d]));
  const min = [Infinity, Infinity, Infinity];
  const max = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < positions.length; i += 3) {
    for (let k = 0; k < 3; k++) {
      min[k] = Math.min(min[k], positions[i + k]);
      max[k] = Math.max(max[k], positions[i + k]);
    }
  }
  const parts = [new Uint8Array(positions.buffer), new Uint8Array(indices.buffer)];
  if (!o.uri) parts.push(o.qm);
  const views = [];
  let length = 0;
  for (const p of parts) {
    views.push({ buffer: 0, byteOffset: length, byteLength: p.length });
    length = pad4(length + p.length);
  }
  views[0].target = 34962;
  views[1].target = 34963;
  const bin = new Uint8Array(length);
  parts.forEach((p, i) => bin.set(p, views[i].byteOffset));
  const ext = {
    ...(o.uri ? { uri: o.uri } : { bufferView: 2 }),
    byteLength: o.qm.length,
    streamStart: o.streamStart ?? 0,
    finestLevel: o.finestLevel ?? 0,
    fallback: { bytes: o.fallbackBytes, level: o.fallbackLevel },
    levels: o.levels ?? [],
  };
  const json = {
    asset: { version: '2.0', generator: 'qm js test (hand-made)' },
    extensionsUsed: ['QM_progressive_mesh'],
    scene: 0,
    scenes: [{ nodes: [0] }],
    nodes: [{ mesh: 0 }],
    meshes: [{ primitives: [{ attributes: { POSITION: 0 }, indices: 1, mode: 4, extensions: { QM_progressive_mesh: ext } }] }],
    accessors: [
      { bufferView: 0, componentType: 5126, count: positions.length / 3, type: 'VEC3', min, max },
      { bufferView: 1, componentType: 5125, count: indices.length, type: 'SCALAR' },
    ],
    bufferViews: views,
    buffers: [{ byteLength: length }],
  };
  const text = new TextEncoder().encode(JSON.stringify(json));
  const jsonLength = pad4(text.length);
  const total = 12 + 8 + jsonLength + 8 + length;
  const out = new Uint8Array(total);
  const view = new DataView(out.buffer);
  view.setUint32(0, 0x46546c67, true); // glTF
  view.setUint32(4, 2, true);
  view.setUint32(8, total, true);
  view.setUint32(12, jsonLength, true);
  view.setUint32(16, 0x4e4f534a, true); // JSON
  out.fill(0x20, 20, 20 + jsonLength);
  out.set(text, 20);
  view.setUint32(20 + jsonLength, length, true);
  view.setUint32(24 + jsonLength, 0x004e4942, true); // BIN
  out.set(bin, 28 + jsonLength);
  fs.writeFileSync(file, out);
}
