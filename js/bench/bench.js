// The page of js/bench/measure.mjs: loads one model either with QMLoader
// (streaming the whole file, or to a maxBytes or maxError goal) or with three.js's
// DRACOLoader (the whole file), and reports when the first frame showing the
// mesh was drawn and how many bytes had arrived then. Both decoders are
// loaded and started before the timed load.

import * as THREE from 'three';
import { DRACOLoader } from 'three/examples/jsm/loaders/DRACOLoader.js';
import { QMLoader } from 'three-qm-loader';

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas });
renderer.setSize(canvas.clientWidth, canvas.clientHeight, false);
const scene = new THREE.Scene();
const camera = new THREE.PerspectiveCamera(40, canvas.clientWidth / canvas.clientHeight, 0.001, 100);
camera.position.set(0, 0.1, 0.5);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404650, 1.4));
const material = new THREE.MeshStandardMaterial({ color: 0xd7b48f });
const frame = () => new Promise((resolve) => requestAnimationFrame(() => { renderer.render(scene, camera); resolve(performance.now()); }));

function bytesOf(name) {
  const e = performance.getEntriesByType('resource').filter((r) => r.name.endsWith(name));
  return e.reduce((n, r) => n + (r.encodedBodySize || 0), 0);
}

window.qmBench = {
  async run(kind, { qm, drc, maxError, maxBytes, level }) {
    try {
      let first = null;
      let done = null;
      let vertices = 0;
      if (kind === 'draco') {
        const loader = new DRACOLoader().setDecoderPath('draco/');
        loader.preload();
        await loader._initDecoder();
        const t0 = performance.now();
        const geometry = await loader.loadAsync(drc);
        scene.add(new THREE.Mesh(geometry, material));
        const t = await frame();
        first = { ms: t - t0, bytes: bytesOf(drc) };
        done = first;
        vertices = geometry.getAttribute('position').count;
        loader.dispose();
      } else {
        const loader = new QMLoader();
        // Start a worker and compile the module before the timed load.
        await loader._getPool().acquire().then((w) => loader._getPool().release(w));
        const t0 = performance.now();
        let firstSeen = null;
        const options = { qmError: { maxError }, qmBytes: { maxBytes }, qmBytesLevel: { maxBytes, level } }[kind] ?? {};
        const stream = loader.stream(qm, {
          ...options,
          requestInit: { cache: 'no-store' },
          onUpdate: (u) => {
            if (!firstSeen) firstSeen = frame().then((t) => ({ ms: t - t0, bytes: u.bytesUsed, received: u.bytes, level: u.level, vertices: u.vertexCount }));
          },
        });
        scene.add(new THREE.Mesh(stream.geometry, material));
        const last = await stream.done;
        const t = await frame();
        first = await firstSeen;
        done = { ms: t - t0, bytes: last.bytes };
        vertices = last.vertexCount;
        loader.dispose();
      }
      return { ok: true, firstMs: first.ms, firstBytes: first.bytes, firstReceived: first.received ?? first.bytes, firstVertices: first.vertices ?? vertices, doneMs: done.ms, doneBytes: done.bytes, vertices };
    } catch (e) {
      return { ok: false, error: String(e && e.message ? e.message : e) };
    }
  },
};
