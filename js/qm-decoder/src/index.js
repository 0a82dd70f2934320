// qm-decoder: the .qm progressive mesh decoder (the native Rust decoder
// compiled to WebAssembly), framework-free, for browsers, Web Workers and
// Node. This module converts types and errors; the decoding, the choice of
// level and the error estimates are the wasm decoder's.

import initWasm, { QmDecoder } from './qm_decoder.js';
import { CODES, QMError, toQMError } from './errors.js';

export { CODES, QMError };

/** The wasm decoder's default memory limit: 512 MiB. */
export const DEFAULT_MAX_MEMORY = 512 * 1024 * 1024;

let loading = null;
let loaded = false;

function fromBase64(text) {
  if (typeof Uint8Array.fromBase64 === 'function') return Uint8Array.fromBase64(text);
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

/**
 * Loads and compiles the WebAssembly decoder once. Without `wasm` the module
 * inlined in this package is used; otherwise `wasm` is a URL or path (fetched),
 * a Response, the module's bytes, or a compiled WebAssembly.Module. Later
 * calls return the first call's promise.
 */
export function ready({ wasm } = {}) {
  if (!loading) {
    loading = (async () => {
      let source = wasm;
      if (source === undefined || source === null) {
        const { default: inline } = await import('./wasm-inline.js');
        if (!inline) throw new TypeError('qm-decoder: this build has no inlined wasm; pass ready({ wasm })');
        source = fromBase64(inline);
      } else if (typeof source === 'string' || source instanceof URL) {
        source = fetch(source);
      } else if (ArrayBuffer.isView(source)) {
        source = new Uint8Array(source.buffer, source.byteOffset, source.byteLength);
      }
      await initWasm({ module_or_path: source });
      loaded = true;
    })();
    loading.catch(() => {
      loading = null; // a failed load may be retried, e.g. with another path
    });
  }
  return loading;
}

/** Whether ready() has finished, so that decoders can be made synchronously. */
export function isReady() {
  return loaded;
}

function levelCode(level) {
  if (level === undefined || level === null || level === 'auto') return -1;
  if (level === 'finest') return -2;
  if (Number.isInteger(level) && level >= -2) return level;
  throw new TypeError(`qm-decoder: level must be 'auto', 'finest' or an integer >= 0, not ${String(level)}`);
}

function checkNumber(name, value, { integer = false } = {}) {
  if (value === undefined || value === null) return;
  if (typeof value !== 'number' || Number.isNaN(value) || value < 0 || (integer && !Number.isInteger(value) && value !== Infinity)) {
    throw new TypeError(`qm-decoder: ${name} must be a ${integer ? 'non-negative integer' : 'non-negative number'}, not ${String(value)}`);
  }
}

function checkOptions(options) {
  if (options === null || typeof options !== 'object') throw new TypeError('qm-decoder: options must be an object');
  checkNumber('maxBytes', options.maxBytes, { integer: true });
  checkNumber('maxError', options.maxError);
  checkNumber('maxTriangles', options.maxTriangles, { integer: true });
  checkNumber('maxMemory', options.maxMemory, { integer: true });
  if (options.toleranceDb !== undefined && !(typeof options.toleranceDb === 'number' && options.toleranceDb >= 0)) {
    throw new TypeError(`qm-decoder: toleranceDb must be a non-negative number, not ${String(options.toleranceDb)}`);
  }
  levelCode(options.level);
}

function bytesOf(chunk) {
  if (chunk instanceof Uint8Array) return chunk;
  if (ArrayBuffer.isView(chunk)) return new Uint8Array(chunk.buffer, chunk.byteOffset, chunk.byteLength);
  if (chunk instanceof ArrayBuffer || (typeof SharedArrayBuffer !== 'undefined' && chunk instanceof SharedArrayBuffer)) {
    return new Uint8Array(chunk);
  }
  throw new TypeError('qm-decoder: bytes must be a Uint8Array, another typed array or an ArrayBuffer');
}

/**
 * A decoder for a .qm stream that arrives in pieces: push() the bytes as they
 * come, refine() when a new mesh is wanted. Call `await ready()` first.
 */
export class StreamDecoder {
  #d;
  #options;
  #pushed = 0;
  #ended = false;
  #last = null;
  // Tells this decoder's textures from every other's (`texture.version`).
  #id = Math.random().toString(36).slice(2);
  // The last mesh's texture and textured triangles, given again while their
  // version stays.
  #texture = null;

  constructor(options = {}) {
    if (!loaded) throw new Error('qm-decoder: call and await ready() before new StreamDecoder()');
    checkOptions(options);
    this.#options = { ...options };
    const maxMemory = options.maxMemory ?? 0;
    try {
      this.#d = new QmDecoder(maxMemory);
    } catch (e) {
      throw toQMError(e);
    }
    this.#configure();
  }

  #decoder() {
    if (!this.#d) throw new Error('qm-decoder: this StreamDecoder was disposed');
    return this.#d;
  }

  #configure() {
    const d = this.#decoder();
    const o = this.#options;
    try {
      d.setLevel(levelCode(o.level));
      d.setMaxError(o.maxError ?? 0);
      d.setMaxTriangles(o.maxTriangles ?? 0);
      if (o.toleranceDb !== undefined) d.setTolerance(o.toleranceDb);
    } catch (e) {
      throw toQMError(e);
    }
  }

  /** The options in force (a copy). */
  get options() {
    return { ...this.#options };
  }

  /**
   * Changes the goal (maxError, maxBytes, level, maxTriangles, toleranceDb),
   * e.g. to go on refining past an earlier maxError; maxMemory stays. The
   * next refine() decodes with the new settings.
   */
  setOptions(options) {
    checkOptions(options);
    const { maxMemory, ...rest } = options;
    this.#options = { ...this.#options, ...rest };
    this.#configure();
    this.#last = null;
  }

  /**
   * Appends the next bytes of the file (bytes past maxBytes are ignored).
   * Returns whether the header and base mesh are complete, so that refine()
   * can give a mesh. Throws a QMError as soon as the bytes show that the file
   * is not .qm, is corrupt or exceeds a limit.
   */
  push(chunk) {
    const d = this.#decoder();
    let bytes = bytesOf(chunk);
    const max = this.#options.maxBytes;
    if (max !== undefined && max !== null) bytes = bytes.subarray(0, Math.max(0, max - this.#pushed));
    this.#pushed += bytes.length;
    try {
      return bytes.length ? d.push(bytes) : d.ready;
    } catch (e) {
      throw toQMError(e);
    }
  }

  /**
   * Decodes what has arrived with the current options. Returns the new mesh,
   * or null when nothing changed (or the base mesh is not complete yet).
   */
  refine() {
    const d = this.#decoder();
    if (!d.ready) return null;
    let changed;
    try {
      changed = d.refine();
    } catch (e) {
      throw toQMError(e);
    }
    if (!changed && this.#last) return null;
    this.#last = this.#mesh();
    return this.#last;
  }

  /**
   * Says that no more bytes will come. Throws a QMError 'truncated' when the
   * header or base mesh is incomplete; otherwise returns refine()'s result.
   */
  end() {
    const d = this.#decoder();
    this.#ended = true;
    if (!d.ready) {
      const needed = this.bytesNeeded;
      const cut = this.#options.maxBytes !== undefined && this.#pushed >= this.#options.maxBytes ? ` (maxBytes ${this.#options.maxBytes})` : '';
      throw new QMError(
        'truncated',
        `the data ended after ${d.bytesReceived} bytes${cut}, inside the header or base mesh of the .qm file${needed ? `: at least ${needed} bytes are needed` : ''}`,
      );
    }
    return this.refine();
  }

  #mesh() {
    const d = this.#d;
    const version = d.textureWidth ? `${this.#id}.${d.textureVersion}` : null;
    if (this.#texture?.texture.version !== version) {
      this.#texture = version && {
        texture: { width: d.textureWidth, height: d.textureHeight, data: d.textureRgba(), version },
        textured: { vertices: d.texturedVertices(), uvs: d.uvs(), indices: d.texturedIndices() },
      };
    }
    return {
      positions: d.positions(),
      normals: d.normals(),
      indices: d.indices(),
      // 8-bit sRGB, r g b per vertex, for a file with colours.
      colors: d.colors() ?? null,
      // For a file with colour finer than its geometry: the texture, and
      // the triangles over vertices with one texture coordinate each (the
      // same objects as the last mesh's while the version stays).
      texture: this.#texture?.texture ?? null,
      textured: this.#texture?.textured ?? null,
      level: d.level,
      finestLevel: d.finestLevel,
      passes: d.passes,
      totalPasses: d.totalPasses,
      bytesUsed: d.bytesUsed,
      bytesReceived: d.bytesReceived,
      error: d.errorEstimate,
      psnr: d.psnrEstimate,
      complete: !d.truncated,
      vertexCount: d.vertexCount,
      triangleCount: d.triangleCount,
    };
  }

  /** Whether the header and base mesh are complete. */
  get ready() {
    return this.#decoder().ready;
  }

  /**
   * Whether more bytes would improve the mesh toward the goal: false once
   * maxError is met, maxBytes have been pushed, or the whole stream decoded.
   */
  get wantsMore() {
    const d = this.#decoder();
    const max = this.#options.maxBytes;
    if (this.#ended) return false;
    if (max !== undefined && max !== null && this.#pushed >= max) return false;
    if (!d.ready) return true;
    return d.wantsMore;
  }

  /** Before the base mesh: the least total bytes it needs, when known, else 0. */
  get bytesNeeded() {
    return this.#decoder().bytesNeeded;
  }

  /** Bytes pushed so far (within maxBytes). */
  get bytesReceived() {
    return this.#decoder().bytesReceived;
  }

  /** Bytes of the header and base mesh (0 before they are complete). */
  get streamStart() {
    return this.#decoder().streamStart;
  }

  /** The file's finest subdivision level (0 before the header). */
  get finestLevel() {
    return this.#decoder().finestLevel;
  }

  /** Bit-plane passes in the complete file (0 before the header). */
  get totalPasses() {
    return this.#decoder().totalPasses;
  }

  /** Whether the file carries vertex colours (false before the header). */
  get hasColors() {
    return this.#decoder().hasColors;
  }

  /** Vertices of the mesh at `level` (0 before the base mesh). */
  vertexCountAt(level) {
    return this.#decoder().vertexCountAt(level);
  }

  /** Triangles of the mesh at `level` (0 before the base mesh). */
  triangleCountAt(level) {
    return this.#decoder().triangleCountAt(level);
  }

  /**
   * A checksum of the last mesh (its quantized positions and triangles), as
   * the native reference decoder prints it; for tests.
   */
  checksum() {
    return this.#decoder().checksum();
  }

  /** Frees the decoder's wasm memory. The decoder cannot be used after. */
  dispose() {
    if (this.#d) {
      this.#d.free();
      this.#d = null;
    }
    this.#last = null;
    this.#texture = null;
  }
}

/**
 * Decodes a whole .qm file, or its first maxBytes, in one call. Options as
 * for StreamDecoder. Rejects with a QMError on bad input.
 */
export async function decode(bytes, options = {}) {
  checkOptions(options);
  const data = bytesOf(bytes);
  await ready();
  const decoder = new StreamDecoder(options);
  try {
    decoder.push(data);
    return decoder.end();
  } finally {
    decoder.dispose();
  }
}
