/** What went wrong, for code that reacts to it. */
export type QMErrorCode =
  | 'not-qm'
  | 'unsupported-version'
  | 'truncated'
  | 'corrupt'
  | 'limit'
  | 'memory'
  | 'internal';

/** The codes a QMError from the decoder may carry. */
export declare const CODES: readonly QMErrorCode[];

/** Every failure of the decoder: bad input, a limit, or (code 'internal') a bug. */
export declare class QMError extends Error {
  constructor(code: string, message: string, options?: { cause?: unknown });
  readonly name: 'QMError';
  /** One of CODES; the three.js loader adds 'http' and 'aborted'. */
  readonly code: QMErrorCode | (string & {});
}

/** The wasm decoder's default memory limit: 512 MiB. */
export declare const DEFAULT_MAX_MEMORY: number;

/** Where the WebAssembly module comes from, when not the inlined one. */
export type WasmSource =
  | string
  | URL
  | Response
  | Promise<Response>
  | ArrayBuffer
  | ArrayBufferView
  | WebAssembly.Module;

/**
 * Loads and compiles the decoder once (the inlined module unless `wasm` says
 * otherwise). Later calls return the first call's promise.
 */
export declare function ready(options?: { wasm?: WasmSource }): Promise<void>;

/** Whether ready() has finished. */
export declare function isReady(): boolean;

export interface DecodeOptions {
  /** Use at most the first maxBytes bytes. */
  maxBytes?: number;
  /** Stop refining once the decoder's error estimate is at most this (RMS, model units). */
  maxError?: number;
  /**
   * The level shown: 'auto' (default: the coarsest level within toleranceDb of
   * the finest by the decoder's estimate), 'finest', or a level >= 0.
   */
  level?: 'auto' | 'finest' | number;
  /** Show no more triangles than this (a coarser level if needed). */
  maxTriangles?: number;
  /** The tolerance of level 'auto', in dB. */
  toleranceDb?: number;
  /** The most memory the file may ask for, in bytes (default 512 MiB). */
  maxMemory?: number;
}

/** One decoded mesh: triangles, each quad split along its first diagonal. */
export interface QMMesh {
  /** x, y, z per vertex. */
  positions: Float32Array;
  /** Unit vertex normals, x, y, z per vertex. */
  normals: Float32Array;
  /** Three vertex indices per triangle, counter-clockwise. */
  indices: Uint32Array;
  /**
   * For a file with colours: r, g, b per vertex, 8-bit sRGB (not linear),
   * one colour per vertex of this mesh; null for a file without.
   */
  colors: Uint8Array | null;
  /**
   * For a file whose colour is finer than its geometry: that colour as a
   * texture atlas, r, g, b, 255 per texel (8-bit sRGB), rows from the top;
   * null for other files. `version` differs between decoders and changes
   * whenever a refinement makes the texture anew: while it stays, `texture`
   * and `textured` are the last mesh's objects, unchanged (a viewer need
   * not upload them again; do not modify or transfer them).
   */
  texture: { width: number; height: number; data: Uint8Array; version: string } | null;
  /**
   * With a texture: the mesh's triangles over vertices that each have one
   * texture coordinate (a vertex of several base quads is one such vertex
   * a quad). `vertices` gives each one's vertex of this mesh (its position,
   * normal and colour), `uvs` its u, v ((0, 0) at the image's top-left
   * corner), `indices` three a triangle in the order of `indices` above.
   */
  textured: { vertices: Uint32Array; uvs: Float32Array; indices: Uint32Array } | null;
  /** The subdivision level shown. */
  level: number;
  /** The file's finest level. */
  finestLevel: number;
  /** Bit-plane passes decoded completely. */
  passes: number;
  /** Passes in the whole file. */
  totalPasses: number;
  /** The prefix length this mesh was decoded from. */
  bytesUsed: number;
  /** Bytes received so far. */
  bytesReceived: number;
  /** The decoder's estimate of the RMS distance to the whole file's mesh (model units). */
  error: number;
  /** The same as a PSNR in dB against the bounding box diagonal. */
  psnr: number;
  /** Whether the whole stream was decoded. */
  complete: boolean;
  vertexCount: number;
  triangleCount: number;
}

/** A decoder for a stream that arrives in pieces. Call `await ready()` first. */
export declare class StreamDecoder {
  constructor(options?: DecodeOptions);
  /** The options in force (a copy). */
  readonly options: DecodeOptions;
  /** Changes the goal for the next refine() (maxMemory stays as it was). */
  setOptions(options: Omit<DecodeOptions, 'maxMemory'>): void;
  /** Appends bytes; true once the header and base mesh are complete. Throws QMError. */
  push(chunk: ArrayBufferView | ArrayBufferLike): boolean;
  /** Decodes what has arrived; null when nothing changed or not ready. Throws QMError. */
  refine(): QMMesh | null;
  /** No more bytes will come: throws QMError 'truncated' before the base mesh, else refine(). */
  end(): QMMesh | null;
  /** Whether the header and base mesh are complete. */
  readonly ready: boolean;
  /** False once the goal is met (maxError, maxBytes) or the whole stream decoded. */
  readonly wantsMore: boolean;
  /** Before ready: the least total bytes the header and base mesh need, if known, else 0. */
  readonly bytesNeeded: number;
  readonly bytesReceived: number;
  /** Bytes of the header and base mesh (0 before they are complete). */
  readonly streamStart: number;
  readonly finestLevel: number;
  readonly totalPasses: number;
  /** Whether the file carries vertex colours (false before the header). */
  readonly hasColors: boolean;
  vertexCountAt(level: number): number;
  triangleCountAt(level: number): number;
  /** The native reference decoder's checksum of the last mesh (16 hex digits). */
  checksum(): string;
  /** Frees the wasm memory of this decoder. */
  dispose(): void;
}

/** Decodes a whole file (or its first maxBytes) at once. Rejects with QMError. */
export declare function decode(bytes: ArrayBufferView | ArrayBufferLike, options?: DecodeOptions): Promise<QMMesh>;
