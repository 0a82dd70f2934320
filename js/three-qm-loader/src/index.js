// three-qm-loader: a three.js loader for .qm progressive meshes and a
// GLTFLoader plugin for the glTF extension QM_progressive_mesh.

export { QMLoader, QMStream, applyMesh } from './QMLoader.js';
export { GLTFQMExtension } from './GLTFQMExtension.js';
export { QMError } from './errors.js';
