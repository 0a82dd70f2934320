// Where a stream's bytes come from: a URL read by HTTP Range requests, or
// bytes already in memory (a GLB's bufferView).
//
// The Range client follows PMTiles' FetchSource: it asks for exactly the
// bytes wanted (`Range: bytes=START-END`), tolerates a server that ignores
// Range and answers 200 with the whole file (it then skips to START, reads the
// body as a stream and cancels it when enough arrived), takes 416 as the end
// of the file, and trusts no length the server did not send.

import { QMError } from './errors.js';

const isAbort = (e) => e && (e.name === 'AbortError' || e.code === 'aborted');

// `bytes A-B/TOTAL` (TOTAL may be `*`) or `bytes */TOTAL`.
function parseContentRange(value) {
  const m = /^\s*bytes\s+(?:(\d+)-(\d+)|\*)\s*\/\s*(\d+|\*)\s*$/i.exec(value ?? '');
  if (!m) return null;
  return {
    first: m[1] === undefined ? null : Number(m[1]),
    last: m[2] === undefined ? null : Number(m[2]),
    total: m[3] === '*' ? null : Number(m[3]),
  };
}

export class UrlSource {
  /**
   * @param {string} url
   * @param {RequestInit} init headers, credentials, cache, ... for every request
   */
  constructor(url, init = {}) {
    this.url = url;
    this.init = init;
    this.total = null; // the file's length, once a server said it
    this.etag = null;
    this.ignoresRange = false; // a server answered a Range request with 200
    this.requests = 0;
  }

  /**
   * Reads bytes from `start`: up to `end` (exclusive; Infinity: to the end of
   * the file) by one request, calling `onChunk(bytes)` for each piece in
   * order. With a server that ignores Range the body is read past `end` up
   * to `limit` while `more()` says so. Resolves to { eof } (whether the file
   * ended); `signal` stops it (the promise then rejects with the abort's
   * reason), `stopSignal` ends it early, resolving.
   */
  async read({ start, end, limit = Infinity, more = () => true, onChunk, signal, stopSignal }) {
    const controller = new AbortController();
    let stopped = false;
    const abort = () => controller.abort(signal.reason);
    if (signal) {
      if (signal.aborted) throw signal.reason;
      signal.addEventListener('abort', abort, { once: true });
    }
    const stop = () => {
      stopped = true;
      controller.abort();
    };
    if (stopSignal?.aborted) return { eof: false };
    stopSignal?.addEventListener('abort', stop, { once: true });
    const headers = new Headers(this.init.headers ?? {});
    const ranged = start > 0 || end !== Infinity;
    if (ranged) headers.set('Range', `bytes=${start}-${end === Infinity ? '' : end - 1}`);
    this.requests++;
    let response;
    try {
      response = await fetch(this.url, { ...this.init, headers, signal: controller.signal });
    } catch (e) {
      signal?.removeEventListener('abort', abort);
      stopSignal?.removeEventListener('abort', stop);
      if (stopped) return { eof: false };
      if (isAbort(e)) throw signal?.reason ?? e;
      throw new QMError('http', `${this.url}: the request failed (${e.message})`, { cause: e });
    }
    try {
      return await this.#body(response, { start, end, limit, more, onChunk, stop, ranged });
    } catch (e) {
      if (stopped && isAbort(e)) return { eof: false };
      if (isAbort(e) && signal?.aborted) throw signal.reason;
      throw e;
    } finally {
      signal?.removeEventListener('abort', abort);
      stopSignal?.removeEventListener('abort', stop);
    }
  }

  #checkEtag(response) {
    const etag = response.headers.get('ETag');
    if (etag && this.etag && etag !== this.etag && !etag.startsWith('W/')) {
      throw new QMError('http', `${this.url}: the file changed on the server between requests (ETag ${this.etag}, now ${etag})`);
    }
    if (etag) this.etag = etag;
  }

  async #body(response, { start, end, limit, more, onChunk, stop, ranged }) {
    let skip = 0; // bytes of the body before `start`
    let until = Math.min(end, limit); // offset after which the body is not wanted
    if (response.status === 416) {
      // Nothing at `start`: the file is shorter. The length, if sent, is in Content-Range.
      const range = parseContentRange(response.headers.get('Content-Range'));
      if (range?.total !== null && range?.total !== undefined) this.total = range.total;
      response.body?.cancel().catch(() => {});
      return { eof: true };
    }
    if (response.status === 206) {
      const range = parseContentRange(response.headers.get('Content-Range'));
      if (!range || range.first === null) {
        throw new QMError('http', `${this.url}: 206 without a usable Content-Range (${response.headers.get('Content-Range')})`);
      }
      if (range.first > start) {
        throw new QMError('http', `${this.url}: asked for bytes from ${start}, the server sent from ${range.first}`);
      }
      this.#checkEtag(response);
      if (range.total !== null) this.total = range.total;
      skip = start - range.first;
      const eofAt = range.last + 1; // where this body ends
      const eof = (this.total !== null && eofAt >= this.total) || (end !== Infinity && eofAt < end);
      const got = await this.#pump(response, skip, start, until, more, onChunk, stop);
      return { eof: eof && got >= eofAt };
    }
    if (response.status === 200) {
      // The whole file: a server without Range, or a request without one.
      if (ranged) this.ignoresRange = true;
      this.#checkEtag(response);
      const length = response.headers.get('Content-Length');
      if (length !== null && !response.headers.get('Content-Encoding') && /^\d+$/.test(length)) {
        this.total = Number(length);
      }
      skip = start;
      until = limit; // read past `end`, as far as wanted, rather than ask again
      const got = await this.#pump(response, skip, start, until, more, onChunk, stop);
      return { eof: got < until };
    }
    response.body?.cancel().catch(() => {});
    throw new QMError('http', `${this.url}: HTTP ${response.status}${response.statusText ? ` ${response.statusText}` : ''}`);
  }

  // Reads the body, drops `skip` bytes, hands on the bytes of file offsets
  // [start, until), stops when `until` is reached or more() says no.
  // Returns the file offset reached.
  async #pump(response, skip, start, until, more, onChunk, stop) {
    if (!response.body) return start;
    const reader = response.body.getReader();
    let at = start - skip; // file offset of the next body byte
    try {
      for (;;) {
        if (at >= until || (at > start && !more())) {
          stop();
          break;
        }
        const { done, value } = await reader.read();
        if (done) break;
        let piece = value;
        if (at < start) piece = piece.subarray(Math.min(piece.length, start - at));
        const from = Math.max(at, start);
        at += value.length;
        if (from + piece.length > until) piece = piece.subarray(0, until - from);
        if (piece.length) onChunk(piece);
      }
    } finally {
      reader.cancel().catch(() => {});
    }
    return Math.min(at, until);
  }
}

/** Bytes already in memory (a GLB's bufferView), read as if by Range. */
export class BytesSource {
  constructor(bytes) {
    this.bytes = bytes;
    this.total = bytes.length;
    this.requests = 0;
  }

  async read({ start, end, limit = Infinity, onChunk, signal }) {
    if (signal?.aborted) throw signal.reason;
    const stop = Math.min(this.total, end, limit);
    if (stop > start) onChunk(this.bytes.subarray(start, stop));
    return { eof: stop >= this.total };
  }
}
