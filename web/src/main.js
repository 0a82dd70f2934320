// The qm viewer: streams a .qm file with fetch and a ReadableStream, pushes
// the bytes into the WebAssembly incremental decoder and refines the shown
// mesh in every frame in which new bytes arrived.
//
// URL options: ?model=NAME (one of models.json), ?file=URL (any .qm URL),
// ?throttle=KBPS (pace the download in the page), ?level=L (show level L),
// ?shading=flat, ?wireframe=1, ?view=X,Y,Z (camera direction).
// window.qmViewer exposes the state, the current mesh and a benchmark for
// tests.

import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import init, { QmDecoder } from '../pkg/qm_wasm.js';

const params = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);

// --- the scene ---------------------------------------------------------

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({
  canvas,
  antialias: true,
  preserveDrawingBuffer: true, // screenshots and pixel checks read it back
});
renderer.setPixelRatio(window.devicePixelRatio);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x20242b);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
camera.position.set(0, 0, 3);
const controls = new OrbitControls(camera, canvas);
controls.enableDamping = true;
scene.add(new THREE.HemisphereLight(0xffffff, 0x404650, 1.4));
const sun = new THREE.DirectionalLight(0xffffff, 1.8);
sun.position.set(1, 2, 3);
camera.add(sun);
scene.add(camera);

const BASE_COLOUR = 0xd7b48f;
const material = new THREE.MeshStandardMaterial({
  color: BASE_COLOUR,
  roughness: 0.65,
  metalness: 0.0,
  side: THREE.DoubleSide,
});
let mesh = null;
// A file's colours are sRGB bytes; three.js takes vertex colours as linear.
const SRGB_TO_LINEAR = Float32Array.from({ length: 256 }, (_, i) => new THREE.Color().setRGB(i / 255, 0, 0, THREE.SRGBColorSpace).r);

function resize() {
  const w = canvas.clientWidth;
  const h = canvas.clientHeight;
  if (canvas.width !== Math.floor(w * renderer.getPixelRatio()) || canvas.height !== Math.floor(h * renderer.getPixelRatio())) {
    renderer.setSize(w, h, false);
    camera.aspect = w / Math.max(h, 1);
    camera.updateProjectionMatrix();
  }
}

function frameCamera(geometry) {
  geometry.computeBoundingSphere();
  const { center, radius } = geometry.boundingSphere;
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 1.05;
  controls.target.copy(center);
  const view = (params.get('view') ?? '0.8,0.35,-1').split(',').map(Number);
  camera.position.copy(center).add(new THREE.Vector3(...view).normalize().multiplyScalar(distance));
  camera.near = distance / 100;
  camera.far = distance * 10;
  camera.updateProjectionMatrix();
  controls.update();
}

// --- state -------------------------------------------------------------

const state = {
  model: null,
  url: null,
  totalBytes: 0,
  bytes: 0,
  streamStart: 0,
  passes: 0,
  totalPasses: 0,
  level: 0,
  finestLevel: 0,
  vertices: 0,
  triangles: 0,
  refinements: 0,
  ttfpMs: null, // navigation start to the first frame showing a mesh
  ttfpBytes: 0, // bytes in at that frame
  fetchMs: null, // navigation start to the request for the file
  firstBytesMs: null,
  lastDecodeMs: 0,
  decodeMs: 0,
  streamEnded: false,
  done: false,
  error: null,
  checksum: null,
  history: [], // one entry per refinement: bytes, passes, vertices, ms
};

let decoder = null;
let pending = [];
let received = [];
let levelChoice = params.has('level') ? Number(params.get('level')) : -1;
let dirty = false;
let paused = false; // tests hold the picture still while they capture it
let resolveDone;
const done = new Promise((resolve) => { resolveDone = resolve; });

function fmtBytes(n) {
  return n >= 1 << 20 ? `${(n / (1 << 20)).toFixed(2)} MB` : n >= 1024 ? `${(n / 1024).toFixed(1)} KB` : `${n} B`;
}

function showStats() {
  $('s-bytes').textContent = state.totalBytes
    ? `${fmtBytes(state.bytes)} / ${fmtBytes(state.totalBytes)}`
    : fmtBytes(state.bytes);
  $('s-passes').textContent = decoder?.ready ? `${state.passes} / ${state.totalPasses}` : '–';
  $('s-level').textContent = decoder?.ready ? `${state.level} / ${state.finestLevel}` : '–';
  $('s-vertices').textContent = state.vertices.toLocaleString('en');
  $('s-triangles').textContent = state.triangles.toLocaleString('en');
  $('s-ttfp').textContent = state.ttfpMs === null ? '–' : `${state.ttfpMs.toFixed(0)} ms`;
  $('s-decode').textContent = `${state.lastDecodeMs.toFixed(1)} ms`;
  $('s-status').textContent = state.error ? `error: ${state.error}` : state.done ? 'complete' : state.streamEnded ? 'decoding' : 'streaming';
  $('progress').style.width = state.totalBytes ? `${(100 * state.bytes / state.totalBytes).toFixed(1)}%` : '0';
}

function fail(message) {
  state.error = String(message);
  state.done = true;
  showStats();
  resolveDone(state);
}

// The level shown: the one chosen, or -1: the level the bytes support
// (the decoder's own choice; the finest once the file is complete).
function shownLevel() {
  return levelChoice >= 0 ? levelChoice : -1;
}

// Decodes everything received so far and replaces the shown mesh.
function refine() {
  const t = performance.now();
  decoder.setLevel(shownLevel());
  const changed = decoder.refine();
  if (!changed) return;
  const positions = decoder.positions();
  const normals = decoder.normals();
  const indices = decoder.indices();
  const ms = performance.now() - t;
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  geometry.setAttribute('normal', new THREE.BufferAttribute(normals, 3));
  geometry.setIndex(new THREE.BufferAttribute(indices, 1));
  const colors = decoder.colors();
  if (colors) geometry.setAttribute('color', new THREE.BufferAttribute(Float32Array.from(colors, (c) => SRGB_TO_LINEAR[c]), 3));
  if (material.vertexColors !== Boolean(colors)) {
    material.vertexColors = Boolean(colors);
    material.color.set(colors ? 0xffffff : BASE_COLOUR);
    material.needsUpdate = true;
  }
  if (mesh) {
    mesh.geometry.dispose();
    mesh.geometry = geometry;
  } else {
    mesh = new THREE.Mesh(geometry, material);
    scene.add(mesh);
    frameCamera(geometry);
  }
  Object.assign(state, {
    bytes: decoder.bytesReceived,
    passes: decoder.passes,
    level: decoder.level,
    vertices: decoder.vertexCount,
    triangles: decoder.triangleCount,
    refinements: decoder.refinements,
    lastDecodeMs: ms,
    decodeMs: state.decodeMs + ms,
  });
  state.history.push({ t: performance.now(), bytes: state.bytes, passes: state.passes, vertices: state.vertices, ms });
}

function onReady() {
  state.streamStart = decoder.streamStart;
  state.totalPasses = decoder.totalPasses;
  state.finestLevel = decoder.finestLevel;
  const select = $('level');
  for (let l = 0; l <= state.finestLevel; l++) {
    const option = document.createElement('option');
    option.value = String(l);
    option.textContent = String(l);
    select.append(option);
  }
  select.value = String(levelChoice >= 0 ? Math.min(levelChoice, state.finestLevel) : -1);
}

// One frame: take the bytes that arrived, refine once, draw.
function frame() {
  try {
    if (pending.length && !state.error && !paused) {
      const wasReady = decoder.ready;
      for (const chunk of pending) {
        decoder.push(chunk);
      }
      pending = [];
      state.bytes = decoder.bytesReceived;
      if (decoder.ready) {
        if (!wasReady) onReady();
        refine();
      }
      dirty = true;
    } else if (dirty && decoder?.ready) {
      refine(); // a level change
    }
    if (state.streamEnded && !state.done && pending.length === 0 && !paused) {
      if (!decoder.ready) {
        fail('the file ended inside the header or base mesh');
      } else {
        refine(); // the finest level once everything is in
        state.done = true;
        state.checksum = decoder.checksum();
      }
    }
  } catch (e) {
    fail(e.message ?? e);
  }
  dirty = false;
  resize();
  controls.update();
  renderer.render(scene, camera);
  if (mesh && state.ttfpMs === null) {
    state.ttfpMs = performance.now();
    state.ttfpBytes = state.bytes;
  }
  showStats();
  if (state.done && !state.resolved) {
    state.resolved = true;
    resolveDone(state);
  }
}

// --- streaming -----------------------------------------------------------

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

async function stream(url, throttleKbps) {
  state.fetchMs = performance.now();
  const response = await fetch(url, { cache: 'no-store' });
  if (!response.ok) throw new Error(`${url}: HTTP ${response.status}`);
  const length = Number(response.headers.get('content-length'));
  if (length) state.totalBytes = length;
  const reader = response.body.getReader();
  const start = performance.now();
  let sent = 0;
  for (;;) {
    const { done: ended, value } = await reader.read();
    if (ended) break;
    if (state.firstBytesMs === null) state.firstBytesMs = performance.now();
    received.push(value);
    if (!throttleKbps) {
      pending.push(value);
      continue;
    }
    // Pace the bytes in pieces of a twentieth of a second.
    const rate = throttleKbps * 1024;
    const piece = Math.max(1, Math.floor(rate / 20));
    for (let i = 0; i < value.length; i += piece) {
      const due = start + (1000 * sent) / rate;
      const wait = due - performance.now();
      if (wait > 0) await sleep(wait);
      const part = value.subarray(i, i + piece);
      pending.push(part);
      sent += part.length;
    }
  }
  state.streamEnded = true;
}

function allBytes() {
  const total = received.reduce((n, c) => n + c.length, 0);
  const bytes = new Uint8Array(total);
  let at = 0;
  for (const c of received) {
    bytes.set(c, at);
    at += c.length;
  }
  return bytes;
}

// Decodes the received file `runs` times from scratch (a new decoder each
// time: header, base, layout, stream, lifting, vertex buffers and normals)
// and the base mesh alone; medians in ms. Each run repeats the decode
// enough times to take 20 ms or more (browsers coarsen their clocks).
function bench(runs = 9) {
  const bytes = allBytes();
  const median = (xs) => xs.slice().sort((a, b) => a - b)[Math.floor(xs.length / 2)];
  const once = (prefix) => {
    const d = new QmDecoder(0);
    d.setLevel(-2);
    d.push(prefix);
    d.refine();
    const vertices = d.vertexCount;
    d.free();
    return vertices;
  };
  const reps = new Map();
  const time = (prefix) => {
    if (!reps.has(prefix.length)) {
      const t = performance.now();
      once(prefix);
      reps.set(prefix.length, Math.max(1, Math.ceil(20 / Math.max(performance.now() - t, 0.1))));
    }
    const n = reps.get(prefix.length);
    const t = performance.now();
    let vertices = 0;
    for (let i = 0; i < n; i++) vertices = once(prefix);
    return { ms: (performance.now() - t) / n, vertices };
  };
  const full = [];
  const base = [];
  let vertices = 0;
  for (let i = 0; i < runs; i++) {
    const r = time(bytes);
    full.push(r.ms);
    vertices = r.vertices;
    base.push(time(bytes.subarray(0, state.streamStart)).ms);
  }
  const ms = median(full);
  return {
    bytes: bytes.length,
    vertices,
    runs,
    fullMs: ms,
    baseMs: median(base),
    mbPerS: bytes.length / 1e6 / (ms / 1000),
    verticesPerS: vertices / (ms / 1000),
  };
}

// The last rendered picture, shrunk to `width` pixels wide, as grey levels
// (and with `colours` its RGBA bytes too).
function capture(width = 192, colours = false) {
  const height = Math.round((width * canvas.height) / canvas.width);
  const small = document.createElement('canvas');
  small.width = width;
  small.height = height;
  const g = small.getContext('2d', { willReadFrequently: true });
  g.drawImage(canvas, 0, 0, width, height);
  const rgba = g.getImageData(0, 0, width, height).data;
  const grey = new Array(width * height);
  for (let i = 0; i < grey.length; i++) {
    grey[i] = Math.round((rgba[4 * i] + rgba[4 * i + 1] + rgba[4 * i + 2]) / 3);
  }
  return { width, height, grey, ...(colours ? { rgba: Array.from(rgba) } : {}) };
}

window.qmViewer = {
  state,
  done,
  bench,
  capture,
  pause: (on) => {
    paused = on;
  },
  positions: () => (decoder?.ready ? Array.from(decoder.positions()) : []),
  indices: () => (decoder?.ready ? Array.from(decoder.indices()) : []),
  checksum: () => (decoder?.ready && state.vertices ? decoder.checksum() : null),
};

// --- controls ------------------------------------------------------------

if (params.get('shading') === 'flat') {
  document.querySelector('input[name=shading][value=flat]').checked = true;
  material.flatShading = true;
}
if (params.get('wireframe') === '1') {
  $('wireframe').checked = true;
  material.wireframe = true;
}
for (const radio of document.querySelectorAll('input[name=shading]')) {
  radio.addEventListener('change', () => {
    material.flatShading = radio.value === 'flat' && radio.checked;
    material.needsUpdate = true;
  });
}
$('wireframe').addEventListener('change', (e) => {
  material.wireframe = e.target.checked;
});
$('level').addEventListener('change', (e) => {
  levelChoice = Number(e.target.value);
  dirty = true;
});
$('throttle').value = params.get('throttle') ?? '';
$('reload').addEventListener('click', () => {
  const next = new URLSearchParams(location.search);
  const throttle = $('throttle').value;
  if (throttle && Number(throttle) > 0) next.set('throttle', throttle);
  else next.delete('throttle');
  next.set('model', $('model').value);
  location.search = next.toString();
});
$('model').addEventListener('change', () => $('reload').click());

// --- start ---------------------------------------------------------------

async function main() {
  await init();
  decoder = new QmDecoder(0);
  let url = params.get('file');
  if (!url) {
    const models = await fetch('models.json', { cache: 'no-store' })
      .then((r) => (r.ok ? r.json() : []))
      .catch(() => []);
    const select = $('model');
    for (const m of models) {
      const option = document.createElement('option');
      option.value = m.name;
      option.textContent = `${m.name} (${fmtBytes(m.bytes)})`;
      select.append(option);
    }
    const wanted = params.get('model');
    const model = models.find((m) => m.name === wanted) ?? models[0];
    if (!model) throw new Error('no model: serve one with `qm serve FILE.qm` or pass ?file=URL');
    select.value = model.name;
    state.model = model.name;
    state.totalBytes = model.bytes;
    url = `models/${encodeURIComponent(model.name)}`;
  }
  state.url = url;
  renderer.setAnimationLoop(frame);
  await stream(url, Number(params.get('throttle')) || 0);
}

main().catch((e) => {
  console.error(e);
  renderer.setAnimationLoop(frame);
  fail(e.message ?? e);
});
