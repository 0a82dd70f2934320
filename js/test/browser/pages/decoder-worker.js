// qm-decoder in a module Web Worker: decodes the URL it is sent.
import { decode } from 'qm-decoder';

self.onmessage = async ({ data }) => {
  try {
    const bytes = new Uint8Array(await (await fetch(data.url, { cache: 'no-store' })).arrayBuffer());
    const m = await decode(bytes, data.options);
    self.postMessage({ ok: true, vertexCount: m.vertexCount, level: m.level, complete: m.complete, error: m.error, bytesUsed: m.bytesUsed, positions: Array.from(m.positions.subarray(0, 30)) });
  } catch (e) {
    self.postMessage({ ok: false, error: { name: e.name, code: e.code, message: e.message } });
  }
};
