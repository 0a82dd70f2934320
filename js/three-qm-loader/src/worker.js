// The decoding worker of three-qm-loader, bundled with qm-decoder into one
// self-contained script at build time (build.sh) and started from a Blob URL.
// It holds the decoders of the streams given to it: a stream's decoder state
// stays in one worker, so each refinement resumes where the last one ended.

import { ready, StreamDecoder, QMError } from 'qm-decoder';

const decoders = new Map();
// Per decoder: the version of the texture last sent to the main thread,
// which keeps it (and its textured triangles) until the version changes.
const sentTexture = new WeakMap();

function reply(seq, result, transfer = []) {
  self.postMessage({ seq, ok: true, result }, transfer);
}

function fail(seq, e) {
  const error = e instanceof QMError
    ? { code: e.code, message: e.message }
    : { code: 'internal', message: `decoder worker: ${e && e.message ? e.message : String(e)}` };
  self.postMessage({ seq, ok: false, error });
}

// The state the main thread needs after a push or a refinement, and the
// mesh's buffers (transferred, not copied) when there is a new mesh. A
// texture of the version last sent goes without its texels and triangles
// (`data: null`, `textured: null`): the main thread has them.
function status(decoder, mesh) {
  const transfer = mesh ? [mesh.positions.buffer, mesh.normals.buffer, mesh.indices.buffer] : [];
  if (mesh?.colors) transfer.push(mesh.colors.buffer);
  if (mesh?.texture && sentTexture.get(decoder) === mesh.texture.version) {
    mesh = { ...mesh, texture: { ...mesh.texture, data: null }, textured: null };
  } else if (mesh?.texture) {
    sentTexture.set(decoder, mesh.texture.version);
    transfer.push(mesh.texture.data.buffer);
    transfer.push(mesh.textured.vertices.buffer, mesh.textured.uvs.buffer, mesh.textured.indices.buffer);
  }
  return [
    {
      ready: decoder.ready,
      wantsMore: decoder.wantsMore,
      bytesNeeded: decoder.bytesNeeded,
      bytesReceived: decoder.bytesReceived,
      streamStart: decoder.streamStart,
      finestLevel: decoder.finestLevel,
      totalPasses: decoder.totalPasses,
      mesh,
    },
    transfer,
  ];
}

function decoderOf(id) {
  const d = decoders.get(id);
  if (!d) throw new Error(`no stream ${id}`);
  return d;
}

self.onmessage = async ({ data: m }) => {
  try {
    switch (m.type) {
      case 'init':
        await ready({ wasm: m.wasm });
        reply(m.seq, true);
        break;
      case 'open':
        decoders.set(m.id, new StreamDecoder(m.options));
        reply(m.seq, true);
        break;
      case 'push': {
        const d = decoderOf(m.id);
        for (const chunk of m.chunks) d.push(chunk);
        const mesh = m.end ? d.end() : m.refine ? d.refine() : null;
        reply(m.seq, ...status(d, mesh));
        break;
      }
      case 'configure': {
        const d = decoderOf(m.id);
        d.setOptions(m.options);
        reply(m.seq, ...status(d, d.refine()));
        break;
      }
      case 'close':
        decoders.get(m.id)?.dispose();
        decoders.delete(m.id);
        reply(m.seq, true);
        break;
      default:
        throw new Error(`unknown message ${m.type}`);
    }
  } catch (e) {
    fail(m.seq, e);
  }
};
