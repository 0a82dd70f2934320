// GLTFLoader plugin for the glTF extension QM_progressive_mesh (see
// docs/gltf.md in the qm repository): a primitive whose progressive geometry
// is a .qm stream, in a bufferView of the GLB or an external file by `uri`.
// The primitive's ordinary accessors (the fallback, one level decoded
// exactly) load as usual; once the scene is loaded, the plugin streams the
// .qm and refines the geometry of every mesh made from the primitive in
// place. It never shows a mesh coarser than the fallback: refinements from
// fewer bytes than the fallback's are decoded but not shown.

import { LoaderUtils } from 'three';
import { QMLoader } from './QMLoader.js';

const NAME = 'QM_progressive_mesh';

// The bytes of the first row of the extension's table that meets the goal
// (the client asks for exactly those), or undefined (the whole stream).
function bytesFor(ext, { maxError, maxBytes }) {
  let bytes;
  // An error goal of 0 is the lossless mesh: the whole file (the table's
  // estimate can reach 0 a few passes before the end).
  if (maxError !== undefined && maxError > 0 && Array.isArray(ext.levels)) {
    const row = ext.levels.find((r) => typeof r.error === 'number' && r.error <= maxError);
    if (row) bytes = row.bytes;
  }
  if (maxBytes !== undefined) bytes = bytes === undefined ? maxBytes : Math.min(bytes, maxBytes);
  return bytes;
}

// The update a primitive ends with when its fallback met the goal.
function fallbackUpdate(geometry, ext) {
  const row = Array.isArray(ext.levels) ? ext.levels.find((r) => r.bytes >= ext.fallback.bytes) : undefined;
  return {
    geometry,
    bytes: 0,
    bytesUsed: ext.fallback.bytes,
    total: typeof ext.byteLength === 'number' ? ext.byteLength : null,
    level: ext.fallback.level,
    finestLevel: ext.finestLevel ?? 0,
    passes: row?.passes ?? 0,
    totalPasses: Array.isArray(ext.levels) && ext.levels.length ? ext.levels.at(-1).passes : 0,
    error: ext.fallback.error,
    psnr: NaN,
    complete: false,
    vertexCount: geometry.getAttribute('position')?.count ?? 0,
    triangleCount: (geometry.getIndex()?.count ?? 0) / 3,
  };
}

// The look decoded from the .qm on the meshes' materials: vertex colours
// (a `color` attribute) or a texture (`userData.qmTexture`, for colour finer
// than the geometry) as their map. A material that does not show it yet is
// cloned once (as GLTFLoader does for primitives with COLOR_0), since other
// meshes may share it; `clones` maps each original to its clone, which later
// updates change in place (a stream may go from colours to a texture), and
// each clone to itself. Each stream keeps its own map: two primitives that
// share a material show their own textures.
function showLook(objects, geometry, clones) {
  const map = geometry.userData.qmTexture ?? null;
  const vertexColors = !map && geometry.hasAttribute('color');
  if (!map && !vertexColors) return;
  for (const object of objects) {
    const one = (m) => {
      if (!m) return m;
      // A clone maps to itself.
      let c = clones.get(m);
      if (c !== m && (m.map ?? null) === map && m.vertexColors === vertexColors) return m;
      if (!c) {
        c = m.clone();
        clones.set(m, c);
        clones.set(c, c);
      }
      if ((c.map ?? null) !== map || c.vertexColors !== vertexColors) {
        c.map = map;
        c.vertexColors = vertexColors;
        c.needsUpdate = true;
      }
      return c;
    };
    object.material = Array.isArray(object.material) ? object.material.map(one) : one(object.material);
  }
}

export class GLTFQMExtension {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = NAME;
    const { loader, autoStream = true, onPrimitiveUpdate, ...streamOptions } = options;
    this.loader = loader ?? null;
    this.ownLoader = !loader;
    this.autoStream = autoStream;
    this.onPrimitiveUpdate = onPrimitiveUpdate;
    this.streamOptions = streamOptions;
    this.streams = [];
    this.targets = [];
    let settle;
    this.done = new Promise((resolve, reject) => {
      settle = { resolve, reject };
    });
    this.settle = settle;
    this.done.catch(() => {}); // observed through the promise the caller holds
  }

  // Called by GLTFLoader once the scene is built: find the geometries made
  // from primitives with the extension and stream them (without holding up
  // onLoad: the fallback shows meanwhile).
  afterRoot(result) {
    const json = this.parser.json;
    const seen = new Map();
    for (const scene of result.scenes ?? [result.scene]) {
      scene.traverse((object) => {
        if (!object.isMesh) return;
        const association = this.parser.associations.get(object);
        if (!association || association.meshes === undefined) return;
        const meshIndex = association.meshes;
        const primitiveIndex = association.primitives ?? 0;
        const primitive = json.meshes?.[meshIndex]?.primitives?.[primitiveIndex];
        const ext = primitive?.extensions?.[NAME];
        if (!ext) return;
        if (seen.has(object.geometry)) {
          seen.get(object.geometry).objects.push(object);
          return;
        }
        const target = { geometry: object.geometry, objects: [object], ext, meshIndex, primitiveIndex };
        seen.set(object.geometry, target);
        this.targets.push(target);
      });
    }
    if (this.autoStream) this.stream();
    else if (this.targets.length === 0) this.settle.resolve([]);
    return null;
  }

  /** Streams every primitive's .qm (done by afterRoot unless autoStream is false). */
  stream() {
    if (this.streams.length) return this.done;
    this.loader ??= new QMLoader(this.parser.options.manager);
    const runs = this.targets.map((t) => this.#streamOne(t));
    Promise.all(runs).then(this.settle.resolve, this.settle.reject);
    if (this.ownLoader) this.done.finally(() => this.loader.dispose()).catch(() => {});
    return this.done;
  }

  async #streamOne({ geometry, objects, ext, meshIndex, primitiveIndex }) {
    const { onUpdate, ...rest } = this.streamOptions;
    // A fallback that meets the error goal already: nothing to fetch.
    const fallback = ext.fallback ?? {};
    if (rest.maxError !== undefined && rest.maxError > 0 && typeof fallback.error === 'number' && fallback.error <= rest.maxError) {
      return fallbackUpdate(geometry, ext);
    }
    const maxBytes = bytesFor(ext, rest);
    // This stream's materials cloned to show its look, by their originals.
    const clones = new Map();
    const options = {
      ...rest,
      geometry,
      showFrom: ext.fallback?.bytes ?? 0,
      onUpdate: (u) => {
        showLook(objects, geometry, clones);
        onUpdate?.(u);
        this.onPrimitiveUpdate?.({ ...u, meshIndex, primitiveIndex });
      },
    };
    if (maxBytes !== undefined) options.maxBytes = maxBytes;
    let source;
    if (typeof ext.bufferView === 'number') {
      const buffer = await this.parser.getDependency('bufferView', ext.bufferView);
      source = new Uint8Array(buffer);
    } else if (typeof ext.uri === 'string') {
      source = LoaderUtils.resolveURL(ext.uri, this.parser.options.path ?? '');
      // The glTF's own request settings, unless the options say otherwise.
      const { requestHeader, crossOrigin } = this.parser.options;
      options.requestInit ??= {
        headers: { ...(requestHeader ?? {}) },
        credentials: crossOrigin === 'use-credentials' ? 'include' : 'same-origin',
      };
    } else {
      throw new Error(`${NAME} on mesh ${meshIndex} primitive ${primitiveIndex}: neither bufferView nor uri`);
    }
    const stream = this.loader.stream(source, options);
    this.streams.push(stream);
    const update = await stream.done;
    stream.dispose();
    return update;
  }
}
