// A pool of decoding workers, as three.js's DRACOLoader keeps one: at most
// `limit` workers, started on demand from the bundled worker script, each
// given the compiled WebAssembly module once. A stream is bound to one
// worker for its life; a new stream goes to the least busy worker.

import workerSource from './worker-source.js';
import { QMError } from './errors.js';

export class WorkerPool {
  constructor(limit, loadModule) {
    this.limit = limit;
    this.loadModule = loadModule; // () => Promise<WebAssembly.Module>
    this.workers = [];
    this.url = null;
    this.seq = 0;
  }

  setLimit(limit) {
    this.limit = limit;
  }

  #start() {
    if (!this.url) {
      this.url = URL.createObjectURL(new Blob([workerSource], { type: 'text/javascript' }));
    }
    const entry = { worker: new Worker(this.url), streams: 0, calls: new Map(), dead: null, ready: null };
    entry.worker.onmessage = ({ data }) => {
      const call = entry.calls.get(data.seq);
      if (!call) return;
      entry.calls.delete(data.seq);
      if (data.ok) call.resolve(data.result);
      else call.reject(new QMError(data.error.code, data.error.message));
    };
    // A worker that dies (out of memory, a crash) fails its streams; the
    // page and the other workers go on.
    const die = (message) => {
      entry.dead = new QMError('internal', message);
      for (const call of entry.calls.values()) call.reject(entry.dead);
      entry.calls.clear();
      this.workers = this.workers.filter((w) => w !== entry);
      entry.worker.terminate();
    };
    entry.worker.onerror = (e) => {
      e.preventDefault?.();
      die(`the decoder worker stopped: ${e.message || 'an error in the worker'}`);
    };
    entry.worker.onmessageerror = () => die('the decoder worker sent a message that could not be read');
    entry.ready = this.loadModule().then((module) => this.call(entry, { type: 'init', wasm: module }));
    this.workers.push(entry);
    return entry;
  }

  call(entry, message, transfer = []) {
    if (entry.dead) return Promise.reject(entry.dead);
    const seq = ++this.seq;
    return new Promise((resolve, reject) => {
      entry.calls.set(seq, { resolve, reject });
      entry.worker.postMessage({ ...message, seq }, transfer);
    });
  }

  /** A worker for a new stream: a new one while under the limit and all are busy, else the least busy. */
  async acquire() {
    let entry = this.workers.reduce((best, w) => (!best || w.streams < best.streams ? w : best), null);
    if (!entry || (entry.streams > 0 && this.workers.length < this.limit)) entry = this.#start();
    entry.streams++;
    try {
      await entry.ready;
    } catch (e) {
      entry.streams--;
      if (this.workers.includes(entry) && !entry.dead) {
        this.workers = this.workers.filter((w) => w !== entry);
        entry.worker.terminate();
      }
      throw e;
    }
    return entry;
  }

  release(entry) {
    entry.streams = Math.max(0, entry.streams - 1);
  }

  dispose() {
    for (const entry of this.workers) {
      entry.worker.terminate();
      for (const call of entry.calls.values()) call.reject(new QMError('aborted', 'the loader was disposed'));
    }
    this.workers = [];
    if (this.url) URL.revokeObjectURL(this.url);
    this.url = null;
  }
}
