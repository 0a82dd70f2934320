// QMLoader: a three.js Loader for .qm progressive meshes. Decodes off the main
// thread in a pool of workers (as DRACOLoader does), fetches by HTTP Range
// only the prefix a goal needs, and refines one BufferGeometry in place as
// the bytes arrive.

import {
  BufferAttribute,
  BufferGeometry,
  DataTexture,
  LinearFilter,
  LinearMipmapLinearFilter,
  Loader,
  RGBAFormat,
  SRGBColorSpace,
} from 'three';
import { QMError } from './errors.js';
import { WorkerPool } from './pool.js';
import { BytesSource, UrlSource } from './source.js';

const DECODER_FILE = 'qm_decoder_bg.wasm';

// The first range asked for when the goal is an error and the length of the
// header and base mesh is not known yet; later ranges double what arrived.
const FIRST_RANGE = 16 * 1024;

function fromBase64(text) {
  if (typeof Uint8Array.fromBase64 === 'function') return Uint8Array.fromBase64(text);
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

const GOAL_KEYS = ['maxBytes', 'maxError', 'level', 'maxTriangles', 'toleranceDb'];

function goalOf(options) {
  const goal = {};
  for (const k of GOAL_KEYS) if (options[k] !== undefined) goal[k] = options[k];
  return goal;
}

function progressEvent(loaded, total) {
  const init = { lengthComputable: total !== null, loaded, total: total ?? 0 };
  return typeof ProgressEvent === 'function' ? new ProgressEvent('progress', init) : { type: 'progress', ...init };
}

// The decoder's colours are 8-bit sRGB; three.js takes vertex colours as
// linear (its working colour space) and encodes the output to sRGB, so each
// value goes through the sRGB transfer function's inverse here, or dark
// tones would come out too light. Stored as normalized Uint16: every 8-bit
// sRGB value keeps a value of its own (the smallest linear step, 1/255/12.92,
// is about 20 steps of 1/65535) and the output rounds back to the input
// byte, at half the memory and upload of Float32; Uint8 would merge the
// darkest codes (banding).
let linearTable = null;
function srgbToLinear16(colors, out) {
  if (!linearTable) {
    linearTable = new Uint16Array(256);
    for (let i = 0; i < 256; i++) {
      const c = i / 255;
      const linear = c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055) ** 2.4;
      linearTable[i] = Math.round(linear * 65535);
    }
  }
  for (let i = 0; i < colors.length; i++) out[i] = linearTable[colors[i]];
  return out;
}

// A mesh with a texture as three.js draws it: its textured triangles, each
// vertex's position and normal gathered from the mesh's; the texture shows
// the colour, so no vertex colours.
function texturedMesh(mesh) {
  const t = mesh.textured;
  const positions = new Float32Array(3 * t.vertices.length);
  const normals = new Float32Array(3 * t.vertices.length);
  for (let k = 0; k < t.vertices.length; k++) {
    const v = 3 * t.vertices[k];
    positions.set(mesh.positions.subarray(v, v + 3), 3 * k);
    normals.set(mesh.normals.subarray(v, v + 3), 3 * k);
  }
  return { ...mesh, positions, normals, indices: t.indices, colors: null, uvs: t.uvs };
}

// The geometry's texture (`userData.qmTexture`): one DataTexture for the
// geometry's life, so that a material keeps it as its map. Its image is
// updated in place, or replaced (the GPU texture freed first) when the atlas
// grows as the colour reaches finer levels; removed without a texture. A
// texture of the version it holds (the refinement advanced the geometry
// alone) is not uploaded again.
function applyTexture(geometry, texture) {
  let map = geometry.userData.qmTexture;
  if (!texture) {
    map?.dispose();
    delete geometry.userData.qmTexture;
    return;
  }
  const { width, height, data } = texture;
  if (!map) {
    // Row 0 at v = 0, as glTF has texture coordinates (no flip).
    map = new DataTexture(data, width, height, RGBAFormat);
    map.colorSpace = SRGBColorSpace;
    map.magFilter = LinearFilter;
    map.minFilter = LinearMipmapLinearFilter;
    map.generateMipmaps = true;
    geometry.userData.qmTexture = map;
  } else if (map.image.width === width && map.image.height === height) {
    if (texture.version !== undefined && map.userData.qmVersion === texture.version) return;
    // The new texels themselves, not a copy: the stream keeps them too.
    map.image.data = data;
  } else {
    map.dispose();
    map.image = { data, width, height };
  }
  map.userData.qmVersion = texture.version;
  map.needsUpdate = true;
}

/**
 * Puts a decoded mesh into `geometry`, reusing its buffers when the sizes
 * allow. A mesh with `colors` (qm-decoder's sRGB bytes) gives the geometry a
 * `color` attribute in linear values; one without removes it. A mesh with a
 * texture (colour finer than the geometry) gives it its textured triangles
 * with a `uv` attribute, and the texture as `geometry.userData.qmTexture` (a
 * DataTexture for a material's `map`), instead of colours.
 */
export function applyMesh(geometry, decoded) {
  const mesh = decoded.textured ? texturedMesh(decoded) : decoded;
  applyTexture(geometry, decoded.textured ? decoded.texture : null);
  const uvs = mesh.uvs ?? null;
  const uv = geometry.getAttribute('uv');
  const position = geometry.getAttribute('position');
  const normal = geometry.getAttribute('normal');
  const color = geometry.getAttribute('color');
  const index = geometry.getIndex();
  const colors = mesh.colors ?? null;
  const same = position && normal && index
    && position.array.length === mesh.positions.length
    && index.array.length === mesh.indices.length
    && (colors ? color?.array.length === colors.length : !color)
    && (uvs ? uv?.array.length === uvs.length : !uv)
    && geometry.userData.qmLevel === mesh.level;
  if (same) {
    position.array.set(mesh.positions);
    position.needsUpdate = true;
    normal.array.set(mesh.normals);
    normal.needsUpdate = true;
    if (colors) {
      srgbToLinear16(colors, color.array);
      color.needsUpdate = true;
    }
    if (uvs) {
      uv.array.set(uvs);
      uv.needsUpdate = true;
    }
  } else {
    // New sizes: free the GPU buffers of the old ones; the renderer uploads
    // the new attributes at the next frame, the geometry object stays.
    if (position) geometry.dispose();
    for (const name of Object.keys(geometry.attributes)) {
      if (name !== 'position' && name !== 'normal') geometry.deleteAttribute(name);
    }
    geometry.morphAttributes = {};
    geometry.setAttribute('position', new BufferAttribute(mesh.positions, 3));
    geometry.setAttribute('normal', new BufferAttribute(mesh.normals, 3));
    if (colors) {
      geometry.setAttribute('color', new BufferAttribute(srgbToLinear16(colors, new Uint16Array(colors.length)), 3, true));
    }
    if (uvs) geometry.setAttribute('uv', new BufferAttribute(uvs, 2));
    geometry.setIndex(new BufferAttribute(mesh.indices, 1));
  }
  geometry.userData.qmLevel = mesh.level;
  geometry.computeBoundingBox();
  geometry.computeBoundingSphere();
}

let streamIds = 0;

/**
 * One .qm stream refining one BufferGeometry: made by QMLoader.stream().
 * `done` settles when the current goal is met (or the file ended);
 * resume() sets a new goal and goes on from the bytes already received.
 */
export class QMStream {
  // The last texture and textured triangles the worker sent.
  #kept = null;

  constructor(loader, source, options = {}) {
    this.loader = loader;
    this.source = source;
    this.geometry = options.geometry ?? new BufferGeometry();
    this.id = ++streamIds;
    this.goal = goalOf(options);
    this.maxMemory = options.maxMemory;
    this.onUpdate = options.onUpdate;
    this.onProgress = options.onProgress;
    this.signal = options.signal;
    this.firstRange = options.firstRange ?? FIRST_RANGE;
    this.showFrom = options.showFrom ?? 0;
    // The state of the last update.
    this.bytes = 0; // bytes received
    this.bytesUsed = 0;
    this.level = -1;
    this.finestLevel = 0;
    this.passes = 0;
    this.totalPasses = 0;
    this.error = NaN;
    this.psnr = NaN;
    this.complete = false;
    this.updates = 0;
    this.ready = false;
    this.wantsMore = true;
    this.bytesNeeded = 0;
    this.eof = false;
    this.running = false;
    this.disposed = false;
    this.failure = null;
    this.pending = [];
    this.busy = null;
    this.stopper = null;
    this.entry = null;
    this.done = this.#run();
  }

  get total() {
    return this.source.total;
  }

  /** Goes on toward a new goal (e.g. a smaller maxError), from the bytes already in. */
  resume(options = {}) {
    if (this.disposed) return Promise.reject(new QMError('aborted', 'this stream was disposed'));
    if (this.running) return Promise.reject(new Error('three-qm-loader: resume() while the stream is still loading; await stream.done first'));
    if (this.failure) return Promise.reject(this.failure);
    const goal = goalOf(options);
    for (const k of GOAL_KEYS) if (k in options && options[k] === undefined) delete this.goal[k];
    Object.assign(this.goal, goal);
    this.signal = options.signal; // a signal stops one run: stream()'s or this one
    if (options.onUpdate !== undefined) this.onUpdate = options.onUpdate;
    this.done = this.#run(true);
    return this.done;
  }

  /** Stops fetching and frees the worker's decoder; the geometry stays. */
  dispose() {
    if (this.disposed) return;
    this.disposed = true;
    this.#kept = null;
    this.stopper?.abort();
    if (this.entry) {
      const { entry } = this;
      this.entry = null;
      this.loader._pool?.call(entry, { type: 'close', id: this.id }).catch(() => {});
      this.loader._pool?.release(entry);
    }
  }

  #update() {
    return {
      geometry: this.geometry,
      bytes: this.bytes,
      bytesUsed: this.bytesUsed,
      total: this.total,
      level: this.level,
      finestLevel: this.finestLevel,
      passes: this.passes,
      totalPasses: this.totalPasses,
      error: this.error,
      psnr: this.psnr,
      complete: this.complete,
      vertexCount: this.geometry.getAttribute('position')?.count ?? 0,
      triangleCount: (this.geometry.getIndex()?.count ?? 0) / 3,
    };
  }

  #needMore() {
    const max = this.goal.maxBytes;
    return !this.failure && !this.eof && this.wantsMore && !(max !== undefined && this.bytes >= max);
  }

  // The next request: [start, end), read on (a 200) up to `limit`.
  #nextRange() {
    const start = this.bytes;
    const max = this.goal.maxBytes ?? Infinity;
    if (max !== Infinity) return { start, end: max, limit: max };
    if (this.goal.maxError !== undefined) {
      let end = start === 0 ? this.firstRange : start + Math.max(this.firstRange, start);
      if (!this.ready && this.bytesNeeded > end) end = this.bytesNeeded;
      return { start, end, limit: Infinity };
    }
    return { start, end: Infinity, limit: Infinity };
  }

  async #run(resumed = false) {
    this.running = true;
    const pool = this.loader._getPool();
    try {
      if (this.signal?.aborted) throw this.signal.reason;
      if (!this.entry) {
        this.entry = await pool.acquire();
        const options = { ...this.goal };
        if (this.maxMemory !== undefined) options.maxMemory = this.maxMemory;
        await pool.call(this.entry, { type: 'open', id: this.id, options });
      } else if (resumed) {
        await this.#call({ type: 'configure', id: this.id, options: { ...this.goal, ...Object.fromEntries(GOAL_KEYS.filter((k) => !(k in this.goal)).map((k) => [k, undefined])) } });
      }
      if (this.disposed) throw new QMError('aborted', 'this stream was disposed');
      while (this.#needMore()) {
        const { start, end, limit } = this.#nextRange();
        this.stopper = new AbortController();
        const { eof } = await this.source.read({
          start,
          end,
          limit,
          more: () => this.wantsMore && !this.failure,
          onChunk: (chunk) => this.#chunk(chunk),
          signal: this.signal,
          stopSignal: this.stopper.signal,
        });
        if (eof || (this.bytes === start && !this.failure && !this.stopper.signal.aborted)) this.eof = true;
        await this.#drain();
      }
      await this.#drain(this.eof);
      if (this.failure) throw this.failure;
      if (!this.ready) {
        const max = this.goal.maxBytes;
        throw new QMError('truncated', `the first ${max} bytes (maxBytes) end inside the header or base mesh of the .qm file${this.bytesNeeded ? `: at least ${this.bytesNeeded} bytes are needed` : ''}`);
      }
      return this.#update();
    } catch (e) {
      this.stopper?.abort();
      // Let the worker finish what it has (it may still be decoding).
      await this.busy?.catch(() => {});
      // A bad file stays failed; after a network error or an abort,
      // resume() may try again from the bytes already in.
      // So may a maxBytes that ended inside the base mesh, with a larger one.
      const retry = !(e instanceof QMError) || e.code === 'http' || e.code === 'aborted'
        || (e.code === 'truncated' && !this.eof && this.goal.maxBytes !== undefined);
      if (retry) this.failure = null;
      else this.failure ??= e;
      throw e;
    } finally {
      this.running = false;
    }
  }

  #chunk(chunk) {
    this.pending.push(chunk);
    this.bytes += chunk.length;
    this.onProgress?.(progressEvent(this.bytes, this.total));
    this.#kick();
  }

  #kick() {
    if (this.busy || this.pending.length === 0 || this.failure) return;
    this.busy = this.#send(false).finally(() => {
      this.busy = null;
      this.#kick();
    });
  }

  async #call(message) {
    const r = await this.loader._pool.call(this.entry, message);
    this.ready = r.ready;
    this.wantsMore = r.wantsMore;
    this.bytesNeeded = r.bytesNeeded;
    this.finestLevel = r.finestLevel;
    this.totalPasses = r.totalPasses;
    if (r.mesh) this.#apply(r.mesh);
    if (!this.wantsMore) this.stopper?.abort();
    return r;
  }

  async #send(end) {
    const chunks = this.pending;
    this.pending = [];
    try {
      if (this.disposed) throw new QMError('aborted', 'this stream was disposed');
      await this.#call({ type: 'push', id: this.id, chunks, refine: true, end });
    } catch (e) {
      this.failure ??= e;
      this.stopper?.abort();
    }
  }

  async #drain(end = false) {
    while (this.busy) await this.busy;
    if (this.failure) return;
    if (this.pending.length || end) {
      this.busy = this.#send(end);
      await this.busy;
      this.busy = null;
    }
  }

  #apply(mesh) {
    // A texture the worker did not send again is the one it sent last (the
    // geometry's map holds those texels, not a copy).
    if (mesh.texture?.data === null) {
      if (!this.#kept) throw new QMError('internal', 'the decoder worker sent a texture it had not sent before');
      mesh = { ...mesh, texture: this.#kept.texture, textured: this.#kept.textured };
    }
    this.#kept = mesh.texture && { texture: mesh.texture, textured: mesh.textured };
    // A geometry that already shows this many bytes' worth (a glTF fallback)
    // is not replaced by a coarser mesh.
    if (mesh.bytesUsed < this.showFrom) return;
    applyMesh(this.geometry, mesh);
    Object.assign(this, {
      bytesUsed: mesh.bytesUsed,
      level: mesh.level,
      finestLevel: mesh.finestLevel,
      passes: mesh.passes,
      totalPasses: mesh.totalPasses,
      error: mesh.error,
      psnr: mesh.psnr,
      complete: mesh.complete,
    });
    this.updates++;
    if (this.onUpdate) {
      try {
        this.onUpdate(this.#update());
      } catch (e) {
        console.error(e);
      }
    }
  }
}

export class QMLoader extends Loader {
  constructor(manager) {
    super(manager);
    this.decoderPath = '';
    this.workerLimit = 4;
    this.decodeOptions = {};
    this._pool = null;
    this._module = null;
  }

  /** A folder holding qm_decoder_bg.wasm, to fetch it instead of using the inlined copy. */
  setDecoderPath(path) {
    this.decoderPath = path;
    this._module = null;
    return this;
  }

  /** The most decoding workers at once (default 4). */
  setWorkerLimit(limit) {
    this.workerLimit = limit;
    this._pool?.setLimit(limit);
    return this;
  }

  /** Default options of load() and loadAsync(): maxBytes, maxError, level, maxTriangles, toleranceDb, maxMemory. */
  setDecodeOptions(options) {
    this.decodeOptions = { ...options };
    return this;
  }

  _getModule() {
    if (!this._module) {
      this._module = (async () => {
        let bytes;
        if (this.decoderPath) {
          const url = new URL(DECODER_FILE, new URL(this.decoderPath, typeof location !== 'undefined' ? location.href : undefined)).href;
          const response = await fetch(url, { credentials: this.withCredentials ? 'include' : 'same-origin' });
          if (!response.ok) throw new QMError('http', `${url}: HTTP ${response.status}: the decoder was not found (setDecoderPath)`);
          bytes = await response.arrayBuffer();
        } else {
          bytes = fromBase64((await import('./wasm-inline.js')).default);
        }
        return WebAssembly.compile(bytes);
      })();
      this._module.catch(() => {
        this._module = null;
      });
    }
    return this._module;
  }

  _getPool() {
    if (!this._pool) this._pool = new WorkerPool(this.workerLimit, () => this._getModule());
    return this._pool;
  }

  #resolve(url) {
    if (this.path !== undefined && this.path !== '') url = this.path + url;
    return this.manager.resolveURL(url);
  }

  #requestInit(extra = {}) {
    return {
      credentials: this.withCredentials ? 'include' : 'same-origin',
      ...extra,
      headers: { ...this.requestHeader, ...(extra.headers ?? {}) },
    };
  }

  /**
   * Streams a .qm file (a URL, or its bytes) into one BufferGeometry, refined
   * in place as bytes arrive. Options: maxBytes, maxError, level,
   * maxTriangles, toleranceDb, maxMemory, onUpdate(update), onProgress(event),
   * signal (AbortSignal), requestInit (for fetch), geometry (to refine an
   * existing one). Returns a QMStream at once; await its `done`.
   */
  stream(source, options = {}) {
    const { requestInit, ...rest } = options;
    const src = typeof source === 'string' || source instanceof URL
      ? new UrlSource(this.#resolve(String(source)), this.#requestInit(requestInit))
      : new BytesSource(source instanceof Uint8Array ? source : ArrayBuffer.isView(source)
        ? new Uint8Array(source.buffer, source.byteOffset, source.byteLength) : new Uint8Array(source));
    return new QMStream(this, src, rest);
  }

  load(url, onLoad, onProgress, onError) {
    const resolved = this.#resolve(url);
    this.manager.itemStart(resolved);
    const stream = this.stream(url, { ...this.decodeOptions, onProgress });
    stream.done.then(
      () => {
        stream.dispose();
        onLoad?.(stream.geometry);
        this.manager.itemEnd(resolved);
      },
      (e) => {
        stream.dispose();
        if (onError) onError(e);
        else console.error(e);
        this.manager.itemError(resolved);
        this.manager.itemEnd(resolved);
      },
    );
  }

  /** Decodes a whole .qm file in memory (in a worker) into a new BufferGeometry. */
  async parseAsync(bytes, options = {}) {
    const stream = this.stream(bytes, { ...this.decodeOptions, ...options });
    try {
      await stream.done;
      return stream.geometry;
    } finally {
      stream.dispose();
    }
  }

  parse(bytes, onLoad, onError) {
    this.parseAsync(bytes).then(onLoad, onError ?? ((e) => console.error(e)));
  }

  /** Stops the workers. The loader can be used again after (new workers start). */
  dispose() {
    this._pool?.dispose();
    this._pool = null;
    return this;
  }
}
