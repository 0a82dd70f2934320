// Type-checks the packages' declarations as a TypeScript user meets them
// (js/test/run.mjs runs `tsc --noEmit --strict` on this file in the clean
// folder where the tarballs are installed). Not run, only compiled.

import { BufferGeometry, Mesh, MeshStandardMaterial } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { CODES, DEFAULT_MAX_MEMORY, QMError, StreamDecoder, decode, isReady, ready } from 'qm-decoder';
import type { DecodeOptions, QMErrorCode, QMMesh } from 'qm-decoder';
import { GLTFQMExtension, QMLoader, QMError as LoaderError, applyMesh } from 'three-qm-loader';
import type { QMStream, QMUpdate } from 'three-qm-loader';

export async function decoderApi(bytes: Uint8Array): Promise<number> {
  await ready();
  await ready({ wasm: new URL('https://example.invalid/qm_decoder_bg.wasm') });
  const options: DecodeOptions = { maxBytes: 1000, maxError: 0.01, level: 'auto', maxTriangles: 5000, toleranceDb: 0.1, maxMemory: DEFAULT_MAX_MEMORY };
  const mesh: QMMesh = await decode(bytes, options);
  const positions: Float32Array = mesh.positions;
  const indices: Uint32Array = mesh.indices;
  const colors: Uint8Array | null = mesh.colors;
  const d = new StreamDecoder({ level: 'finest' });
  const isReadyNow: boolean = d.push(bytes);
  const next: QMMesh | null = d.refine();
  d.setOptions({ maxError: 0.001 });
  const more: boolean = d.wantsMore && isReady() && isReadyNow && d.hasColors;
  d.end();
  d.dispose();
  try {
    await decode(bytes.buffer);
  } catch (e) {
    if (e instanceof QMError) {
      const code: QMErrorCode | string = e.code;
      console.log(code, e.message, CODES.includes('memory'));
    }
  }
  return positions.length + indices.length + (colors?.length ?? 0) + (next ? next.level : 0) + (more ? 1 : 0);
}

export async function loaderApi(): Promise<BufferGeometry> {
  const loader = new QMLoader().setWorkerLimit(2).setDecoderPath('/libs/qm/').setDecodeOptions({ maxError: 0.001 });
  const controller = new AbortController();
  const stream: QMStream = loader.stream('bunny.qm', {
    maxBytes: 20000,
    signal: controller.signal,
    onUpdate: (u: QMUpdate) => console.log(u.bytes, u.level, u.error, u.psnr, u.complete, u.geometry.uuid),
  });
  const mesh = new Mesh(stream.geometry, new MeshStandardMaterial());
  const last: QMUpdate = await stream.done;
  await stream.resume({ maxError: 0.0001 });
  stream.dispose();
  const geometry: BufferGeometry = await loader.loadAsync('bunny.qm');
  applyMesh(geometry, { positions: new Float32Array(3), normals: new Float32Array(3), indices: new Uint32Array(3), level: 0 });
  applyMesh(geometry, { positions: new Float32Array(3), normals: new Float32Array(3), indices: new Uint32Array(3), level: 0, colors: new Uint8Array(3) });
  const gltf = new GLTFLoader();
  let extension: GLTFQMExtension | null = null;
  gltf.register((parser) => (extension = new GLTFQMExtension(parser, { maxError: 0.001, loader })));
  await gltf.loadAsync('bunny.glb');
  if (extension) await (extension as GLTFQMExtension).done;
  try {
    await loader.parseAsync(new Uint8Array(10));
  } catch (e) {
    if (e instanceof LoaderError && e.code === 'http') console.log(e.message);
  }
  loader.dispose();
  console.log(mesh.id, last.bytes);
  return geometry;
}
