// The test page of three-qm-loader and qm-decoder in a browser, bundled by
// js/test/run.mjs from the installed tarballs. A three.js scene renders every
// frame; window.qmTest runs the loader's features for the test to inspect.

import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { GLTFQMExtension, QMError, QMLoader } from 'three-qm-loader';
import { StreamDecoder, decode, ready } from 'qm-decoder';

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242b);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
scene.add(new THREE.HemisphereLight(0xffffff, 0x404650, 1.4));
const material = new THREE.MeshStandardMaterial({ color: 0xd7b48f, side: THREE.DoubleSide });
let frames = 0;
let shown = null;

function frame(object) {
  const box = new THREE.Box3().setFromObject(object);
  const sphere = box.getBoundingSphere(new THREE.Sphere());
  const distance = (sphere.radius || 1) / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 1.05;
  camera.position.copy(sphere.center).add(new THREE.Vector3(0.8, 0.35, -1).normalize().multiplyScalar(distance));
  camera.near = distance / 100;
  camera.far = distance * 10;
  camera.lookAt(sphere.center);
  camera.updateProjectionMatrix();
}

function show(object) {
  if (shown) scene.remove(shown);
  shown = object;
  scene.add(object);
  frame(object);
}

function loop() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(1, h);
    camera.updateProjectionMatrix();
  }
  renderer.render(scene, camera);
  frames++;
  requestAnimationFrame(loop);
}
requestAnimationFrame(loop);

const loader = new QMLoader();

function errorInfo(e) {
  return { name: e?.name, code: e?.code, message: e?.message ?? String(e), isQMError: e instanceof QMError, isError: e instanceof Error };
}

function geometryInfo(geometry) {
  return {
    positions: Array.from(geometry.getAttribute('position')?.array ?? []),
    indices: Array.from(geometry.getIndex()?.array ?? []),
  };
}

// Fraction of the picture that is not background: the mesh is drawn.
function covered() {
  const small = document.createElement('canvas');
  small.width = 64;
  small.height = 48;
  const g = small.getContext('2d', { willReadFrequently: true });
  g.drawImage(canvas, 0, 0, 64, 48);
  const px = g.getImageData(0, 0, 64, 48).data;
  let n = 0;
  for (let i = 0; i < px.length; i += 4) if (Math.abs(px[i] - px[0]) + Math.abs(px[i + 1] - px[1]) + Math.abs(px[i + 2] - px[2]) > 24) n++;
  return n / (64 * 48);
}

const nextFrames = (n) => new Promise((resolve) => {
  const start = frames;
  const check = () => (frames >= start + n ? resolve() : requestAnimationFrame(check));
  check();
});

let current = null;

window.qmTest = {
  frames: () => frames,
  covered,
  nextFrames,

  // Streams `url` with the loader; resolves with the updates seen, the
  // final state, and (if asked) the final geometry.
  async stream(url, options = {}, { geometry = true, abortAfterUpdates } = {}) {
    const updates = [];
    const controller = new AbortController();
    const t0 = performance.now();
    let firstObject = null;
    const stream = loader.stream(url, {
      ...options,
      requestInit: { cache: 'no-store' },
      signal: controller.signal,
      onUpdate: (u) => {
        updates.push({ t: performance.now() - t0, bytes: u.bytes, bytesUsed: u.bytesUsed, total: u.total, level: u.level, error: u.error, psnr: u.psnr, complete: u.complete, vertexCount: u.vertexCount, triangleCount: u.triangleCount, same: u.geometry === stream.geometry });
        if (abortAfterUpdates && updates.length >= abortAfterUpdates) controller.abort();
      },
    });
    current = stream;
    const mesh = new THREE.Mesh(stream.geometry, material);
    firstObject = mesh;
    show(mesh);
    try {
      const last = await stream.done;
      frame(firstObject);
      await nextFrames(2);
      return { ok: true, updates, last: { ...last, geometry: undefined }, elapsed: performance.now() - t0, ...(geometry ? geometryInfo(stream.geometry) : {}) };
    } catch (e) {
      return { ok: false, error: errorInfo(e), updates, elapsed: performance.now() - t0 };
    }
  },

  // Goes on with the last stream toward a new goal.
  async resume(options, { geometry = true } = {}) {
    const updates = [];
    try {
      const last = await current.resume({ ...options, onUpdate: (u) => updates.push({ bytes: u.bytes, level: u.level, vertexCount: u.vertexCount }) });
      await nextFrames(2);
      return { ok: true, updates, last: { ...last, geometry: undefined }, ...(geometry ? geometryInfo(current.geometry) : {}) };
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
  },

  // loader.loadAsync: the promise's outcome.
  async load(url) {
    try {
      const geometry = await loader.loadAsync(url);
      show(new THREE.Mesh(geometry, material));
      await nextFrames(2);
      return { ok: true, vertexCount: geometry.getAttribute('position').count };
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
  },

  // A loader that fetches the wasm from `decoderPath`; loadAsync with onProgress.
  async loadWithDecoderPath(decoderPath, url) {
    const own = new QMLoader().setDecoderPath(decoderPath).setWorkerLimit(1);
    const progress = [];
    try {
      const geometry = await own.loadAsync(url, (e) => progress.push({ loaded: e.loaded, total: e.total, lengthComputable: e.lengthComputable }));
      return { ok: true, vertexCount: geometry.getAttribute('position').count, progress };
    } catch (e) {
      return { ok: false, error: errorInfo(e), progress };
    } finally {
      own.dispose();
    }
  },

  // qm-decoder itself, on the main thread and in a module worker.
  async decodeHere(url, options = {}) {
    await ready();
    const bytes = new Uint8Array(await (await fetch(url, { cache: 'no-store' })).arrayBuffer());
    try {
      const m = await decode(bytes, options);
      return { ok: true, vertexCount: m.vertexCount, level: m.level, complete: m.complete, error: m.error, bytesUsed: m.bytesUsed, positions: Array.from(m.positions.subarray(0, 30)) };
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
  },
  decodeInWorker(url, options = {}) {
    const worker = new Worker(new URL('./decoder-worker.js', import.meta.url), { type: 'module' });
    return new Promise((resolve) => {
      worker.onmessage = ({ data }) => {
        worker.terminate();
        resolve(data);
      };
      worker.onerror = (e) => {
        worker.terminate();
        resolve({ ok: false, error: { message: e.message } });
      };
      worker.postMessage({ url: new URL(url, location.href).href, options });
    });
  },

  // A coloured file: qm-decoder on this thread in chunks (the colours of
  // every refinement), then the loader (decoding in its workers) into a
  // geometry drawn with vertex colours: the color attribute at every
  // update, and at the end read back to sRGB bytes as three.js outputs them.
  async colours(url) {
    await ready();
    const bytes = new Uint8Array(await (await fetch(url, { cache: 'no-store' })).arrayBuffer());
    const decoded = [];
    const d = new StreamDecoder({ level: 'finest' });
    for (let at = 0; at < bytes.length; at += 509) {
      if (!d.push(bytes.subarray(at, at + 509))) continue;
      const m = d.refine();
      if (m) decoded.push({ bytesUsed: m.bytesUsed, level: m.level, vertexCount: m.vertexCount, colors: m.colors && Array.from(m.colors) });
    }
    d.dispose();
    const updates = [];
    const stream = loader.stream(url, {
      level: 'finest',
      requestInit: { cache: 'no-store' },
      onUpdate: ({ geometry, vertexCount }) => {
        const c = geometry.getAttribute('color');
        updates.push({ vertexCount, count: c?.count, itemSize: c?.itemSize, normalized: c?.normalized, type: c?.array.constructor.name });
      },
    });
    const mesh = new THREE.Mesh(stream.geometry, new THREE.MeshBasicMaterial({ vertexColors: true }));
    show(mesh);
    try {
      await stream.done;
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
    frame(mesh);
    await nextFrames(2);
    const linear = stream.geometry.getAttribute('color').array;
    const shownColors = [];
    const c = new THREE.Color();
    for (let i = 0; i < linear.length; i += 3) {
      const hex = c.setRGB(linear[i] / 65535, linear[i + 1] / 65535, linear[i + 2] / 65535).getHex();
      shownColors.push(hex >> 16, (hex >> 8) & 255, hex & 255);
    }
    return { ok: true, decoded, updates, shownColors, covered: covered() };
  },

  // A file with colour finer than its geometry: the loader gives the
  // geometry its textured triangles (a uv attribute) and the texture.
  async textured(url) {
    await ready();
    const maps = new Set();
    // Three.js's versions of the texture (one an upload) and qm-decoder's.
    const uploads = new Set();
    const versions = new Set();
    const looks = [];
    const mesh = new THREE.Mesh(new THREE.BufferGeometry(), new THREE.MeshBasicMaterial());
    const stream = loader.stream(url, {
      level: 'finest',
      geometry: mesh.geometry,
      requestInit: { cache: 'no-store' },
      // The README's recipe: the material follows the geometry's look.
      onUpdate: ({ geometry }) => {
        const map = geometry.userData.qmTexture ?? null;
        const vertexColors = !map && geometry.hasAttribute('color');
        if (map) {
          maps.add(map);
          uploads.add(map.version);
          versions.add(map.userData.qmVersion);
        }
        looks.push(map ? 'texture' : vertexColors ? 'colors' : 'none');
        if (mesh.material.map !== map || mesh.material.vertexColors !== vertexColors) {
          Object.assign(mesh.material, { map, vertexColors });
          mesh.material.needsUpdate = true;
        }
      },
    });
    show(mesh);
    let update;
    try {
      update = await stream.done;
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
    const g = stream.geometry;
    const map = g.userData.qmTexture;
    frame(mesh);
    await nextFrames(2);
    return {
      ok: true,
      bytesUsed: update.bytesUsed,
      level: update.level,
      uv: g.getAttribute('uv')?.count,
      position: g.getAttribute('position').count,
      color: g.hasAttribute('color'),
      texture: map && { width: map.image.width, height: map.image.height, isDataTexture: map.isDataTexture === true, colorSpace: map.colorSpace },
      shown: mesh.material.map === map,
      distinctMaps: maps.size,
      uploads: uploads.size,
      versions: versions.size,
      looks,
      covered: covered(),
    };
  },

  // A GLB: with plain GLTFLoader (the fallback), or with the plugin.
  async gltf(url, { plugin = false, options = {} } = {}) {
    const gltfLoader = new GLTFLoader();
    let extension = null;
    const updates = [];
    if (plugin) {
      gltfLoader.register((parser) => (extension = new GLTFQMExtension(parser, { ...options, onUpdate: (u) => updates.push({ bytes: u.bytes, level: u.level, vertexCount: u.vertexCount }) })));
    }
    try {
      const gltf = await gltfLoader.loadAsync(url);
      let mesh = null;
      gltf.scene.traverse((o) => { if (o.isMesh && !mesh) mesh = o; });
      mesh.material = material;
      show(gltf.scene);
      const fallback = { vertexCount: mesh.geometry.getAttribute('position').count, triangleCount: mesh.geometry.getIndex().count / 3 };
      await nextFrames(2);
      const fallbackCovered = covered();
      let final = null;
      if (extension) {
        const results = await extension.done;
        await nextFrames(2);
        const color = mesh.geometry.getAttribute('color');
        final = {
          level: results[0].level,
          bytes: results[0].bytes,
          bytesUsed: results[0].bytesUsed,
          error: results[0].error,
          vertexCount: mesh.geometry.getAttribute('position').count,
          sameGeometry: results[0].geometry === mesh.geometry,
          color: color && { count: color.count, type: color.array.constructor.name, vertexColors: mesh.material.vertexColors, sharedMaterialChanged: material.vertexColors },
          map: Boolean(mesh.geometry.userData.qmTexture) && mesh.material.map === mesh.geometry.userData.qmTexture,
          sharedMapChanged: Boolean(material.map),
          ...geometryInfo(mesh.geometry),
        };
      }
      return { ok: true, fallback, fallbackCovered, final, updates, covered: covered() };
    } catch (e) {
      return { ok: false, error: errorInfo(e) };
    }
  },
};
