export { QMError } from '../../qm-decoder/src/errors.js';
