// QMError: every failure of the decoder, with a machine-readable code.

/** The codes a QMError may carry. */
export const CODES = Object.freeze([
  'not-qm', // the bytes are not a .qm file
  'unsupported-version', // a .qm format version this decoder does not read
  'truncated', // the data ended inside the header or base mesh
  'corrupt', // a checksum or a field is wrong
  'limit', // the file asks for more than a decoder limit allows (samples, faces, level)
  'memory', // the file needs more memory than maxMemory
  'internal', // the decoder itself failed (a bug): the message says where
]);

export class QMError extends Error {
  /**
   * @param {string} code one of CODES (or a loader's own: 'http', 'aborted')
   * @param {string} message what went wrong, naming the cause
   * @param {{ cause?: unknown }} [options]
   */
  constructor(code, message, options) {
    super(message, options);
    this.name = 'QMError';
    this.code = code;
  }
}

/** Any value thrown by the wasm decoder, as a QMError. */
export function toQMError(e) {
  if (e instanceof QMError) return e;
  if (typeof WebAssembly !== 'undefined' && e instanceof WebAssembly.RuntimeError) {
    return new QMError('internal', `the decoder stopped on an internal error (${e.message}); please report the file`, { cause: e });
  }
  const message = e instanceof Error ? e.message : String(e);
  const code = e && typeof e.code === 'string' && CODES.includes(e.code) ? e.code : 'internal';
  return new QMError(code, message, { cause: e });
}
