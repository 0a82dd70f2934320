import { BufferGeometry, Loader, LoadingManager } from 'three';

/** Every failure: the decoder's codes, plus 'http' (a request failed) and 'aborted'. */
export declare class QMError extends Error {
  constructor(code: string, message: string, options?: { cause?: unknown });
  readonly name: 'QMError';
  readonly code:
    | 'not-qm'
    | 'unsupported-version'
    | 'truncated'
    | 'corrupt'
    | 'limit'
    | 'memory'
    | 'internal'
    | 'http'
    | 'aborted'
    | (string & {});
}

/** A goal: how much to fetch and what to show. */
export interface QMGoal {
  /** Fetch and decode at most the first maxBytes bytes (one Range request). */
  maxBytes?: number;
  /** Stop fetching once the decoder's error estimate is at most this (RMS, model units). */
  maxError?: number;
  /** 'auto' (default: the coarsest level the bytes support), 'finest', or a level >= 0. */
  level?: 'auto' | 'finest' | number;
  /** Show no more triangles than this. */
  maxTriangles?: number;
  /** The tolerance of level 'auto', in dB. */
  toleranceDb?: number;
}

export interface QMDecodeOptions extends QMGoal {
  /** The most memory a file may ask of the decoder, in bytes (default 512 MiB). */
  maxMemory?: number;
}

/** What onUpdate receives after each refinement. */
export interface QMUpdate {
  geometry: BufferGeometry;
  /** Bytes received so far. */
  bytes: number;
  /** The prefix the shown mesh was decoded from. */
  bytesUsed: number;
  /** The file's length, if a server sent it, else null. */
  total: number | null;
  level: number;
  finestLevel: number;
  passes: number;
  totalPasses: number;
  /** The decoder's estimate of the RMS distance to the whole file's mesh (model units). */
  error: number;
  /** The same as a PSNR in dB against the bounding box diagonal. */
  psnr: number;
  /** Whether the whole stream was decoded. */
  complete: boolean;
  vertexCount: number;
  triangleCount: number;
}

export interface QMStreamOptions extends QMDecodeOptions {
  /** Called after each refinement of the geometry. */
  onUpdate?: (update: QMUpdate) => void;
  /** Called as bytes arrive. */
  onProgress?: (event: ProgressEvent | { loaded: number; total: number; lengthComputable: boolean }) => void;
  /** Aborts fetching; `done` then rejects with the signal's reason. */
  signal?: AbortSignal;
  /** Passed to fetch for every request (headers, credentials, cache, ...). */
  requestInit?: RequestInit;
  /** Refine this geometry instead of a new one. */
  geometry?: BufferGeometry;
  /** The first Range request's length when the goal is maxError (default 16384). */
  firstRange?: number;
}

/** One stream refining one geometry; made by QMLoader.stream(). */
export declare class QMStream {
  /** Refined in place as bytes arrive: add it to a Mesh at once. */
  readonly geometry: BufferGeometry;
  /** Settles when the current goal is met or the file ended; rejects with QMError or the abort reason. */
  readonly done: Promise<QMUpdate>;
  readonly bytes: number;
  readonly bytesUsed: number;
  readonly total: number | null;
  readonly level: number;
  readonly error: number;
  readonly psnr: number;
  readonly complete: boolean;
  /**
   * Sets a new goal (e.g. a smaller maxError) and goes on from the bytes
   * already received, by Range. Also after an abort or a network error; not
   * after a bad file. `signal` stops this run only (stream()'s does not).
   */
  resume(options?: QMGoal & { signal?: AbortSignal; onUpdate?: (update: QMUpdate) => void }): Promise<QMUpdate>;
  /** Stops fetching and frees the worker's decoder (the geometry stays). */
  dispose(): void;
}

export declare class QMLoader extends Loader<BufferGeometry> {
  constructor(manager?: LoadingManager);
  /** A folder holding qm_decoder_bg.wasm, fetched instead of the inlined copy. */
  setDecoderPath(path: string): this;
  /** The most decoding workers (default 4). */
  setWorkerLimit(limit: number): this;
  /** Default options of load(), loadAsync() and parse(). */
  setDecodeOptions(options: QMDecodeOptions): this;
  /** Streams a .qm (URL or bytes) into one geometry refined in place. */
  stream(source: string | URL | ArrayBufferLike | ArrayBufferView, options?: QMStreamOptions): QMStream;
  load(
    url: string,
    onLoad?: (geometry: BufferGeometry) => void,
    onProgress?: (event: ProgressEvent) => void,
    onError?: (err: unknown) => void,
  ): void;
  /** Decodes a .qm in memory, in a worker. */
  parseAsync(bytes: ArrayBufferLike | ArrayBufferView, options?: QMDecodeOptions): Promise<BufferGeometry>;
  parse(bytes: ArrayBufferLike | ArrayBufferView, onLoad: (geometry: BufferGeometry) => void, onError?: (err: unknown) => void): void;
  /** Stops the workers. */
  dispose(): this;
}

/**
 * Puts a decoded mesh's arrays into a geometry (reusing buffers of the same
 * size). `colors` (8-bit sRGB, as qm-decoder gives them) become a `color`
 * attribute of linear values (normalized Uint16); without them the geometry
 * has no `color` attribute. A mesh with a `texture` and `textured`
 * triangles (a file whose colour is finer than its geometry) gives the
 * geometry those triangles with a `uv` attribute and no `color`, and the
 * texture as `geometry.userData.qmTexture`, a DataTexture (sRGB) to use as
 * a material's `map`; the glTF extension sets it on the meshes' materials.
 * A texture of the `version` the geometry's texture already shows (a
 * refinement that advanced the geometry alone) is not uploaded again.
 */
export declare function applyMesh(
  geometry: BufferGeometry,
  mesh: {
    positions: Float32Array;
    normals: Float32Array;
    indices: Uint32Array;
    level: number;
    colors?: Uint8Array | null;
    texture?: { width: number; height: number; data: Uint8Array; version?: string } | null;
    textured?: { vertices: Uint32Array; uvs: Float32Array; indices: Uint32Array } | null;
  },
): void;

export interface GLTFQMExtensionOptions extends QMStreamOptions {
  /** The loader to decode with (default: a new QMLoader). */
  loader?: QMLoader;
  /**
   * Whether to stream the .qm after the scene loaded (default true). With
   * false the fallback stays until stream() is called on the extension.
   */
  autoStream?: boolean;
  /** Called for each primitive's update, with the primitive's glTF mesh and primitive index. */
  onPrimitiveUpdate?: (update: QMUpdate & { meshIndex: number; primitiveIndex: number }) => void;
}

/**
 * GLTFLoader plugin for QM_progressive_mesh:
 * `gltfLoader.register((parser) => new GLTFQMExtension(parser, options))`.
 * The primitive's accessors (the fallback) load as usual; the plugin then
 * streams the primitive's .qm and refines the geometry in place.
 */
export declare class GLTFQMExtension {
  constructor(parser: unknown, options?: GLTFQMExtensionOptions);
  readonly name: 'QM_progressive_mesh';
  /** The streams started for this file, once the scene is loaded. */
  readonly streams: QMStream[];
  /** Resolves when every primitive's stream met its goal. */
  readonly done: Promise<QMUpdate[]>;
}
