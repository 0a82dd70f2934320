// Shared helpers of the packages' tests and measurements: paths, the qm
// binaries, `qm serve` (with its request log), headless Chromium through
// playwright-core.

import { execFileSync, execSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const js = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
export const root = path.dirname(js);
const target = process.env.CARGO_TARGET_DIR ? path.resolve(root, process.env.CARGO_TARGET_DIR) : path.join(root, 'target');
/** Where js/build.sh puts the tarballs, and the tests their clean folders. */
export const out = path.join(target, 'js');

// Release builds: `cargo build --release -p qm-cli -p qm-wasm --bins --examples`.
export const bins = {
  qm: process.env.QM_BIN ?? path.join(target, 'release', 'qm'),
  reference: path.join(target, 'release', 'examples', 'reference'),
  bench: path.join(target, 'release', 'examples', 'bench'),
  coloured: path.join(target, 'release', 'examples', 'coloured'),
};

/**
 * Writes the coloured test file (a bumpy sphere with a colour per vertex,
 * `cargo run -p qm-wasm --example coloured`) to `file`, and beside it the
 * colours the whole file decodes to at its finest level (`.rgb`: r, g, b
 * bytes per vertex). Returns { bytes, rgb }.
 */
export function coloured(file) {
  execFileSync(bins.coloured, [file], { stdio: 'inherit' });
  return { bytes: fs.readFileSync(file), rgb: fs.readFileSync(file.replace(/\.qm$/, '.rgb')) };
}

/** FNV-1a (64 bit, 16 hex digits) of bytes: the reference example's `colours`. */
export function fnv1a(bytes) {
  let h = 0xcbf29ce484222325n;
  for (const b of bytes) h = ((h ^ BigInt(b)) * 0x100000001b3n) & 0xffffffffffffffffn;
  return h.toString(16).padStart(16, '0');
}

export function scratch(name) {
  return fs.mkdtempSync(path.join(os.tmpdir(), `qm-js-${name}-`));
}

/** Compresses `input` (a path relative to the repository, or absolute) into `output`. */
export function compress(input, output, extra = []) {
  execFileSync(bins.qm, ['compress', path.resolve(root, input), '-o', output, '--quiet', ...extra], { stdio: 'inherit' });
  return fs.readFileSync(output);
}

/** One JSON line from the native reference decoder. */
export function reference(file, bytes, level) {
  const args = [file, String(bytes)];
  if (level !== undefined) args.push(String(level));
  return JSON.parse(execFileSync(bins.reference, args, { encoding: 'utf8' }));
}

/**
 * Starts `qm serve` on a free port with `web` as its page folder; resolves to
 * { url, stop, log }: `log` holds its stderr lines (one per request once the
 * server logs requests, as `GET /models/x.qm range=0-99 -> 206 100`).
 */
export function serve(file, { throttle, web } = {}) {
  const args = ['serve', file, '--port', '0'];
  if (throttle) args.push('--throttle', String(throttle));
  if (web) args.push('--web', web);
  const child = spawn(bins.qm, args, { stdio: ['ignore', 'pipe', 'pipe'] });
  const log = [];
  let rest = '';
  child.stderr.on('data', (d) => {
    rest += d;
    const lines = rest.split('\n');
    rest = lines.pop();
    log.push(...lines);
  });
  return new Promise((resolve, reject) => {
    let outText = '';
    child.stdout.on('data', (d) => {
      outText += d;
      if (outText.includes('\n')) {
        resolve({ url: outText.split('\n')[0].trim(), stop: () => child.kill(), log });
      }
    });
    child.on('exit', (code) => reject(new Error(`qm serve exited with ${code}: ${log.join('\n')}${rest}`)));
    child.on('error', reject);
  });
}

/**
 * The requests `qm serve` logged for `urlPath` as { method, path, range,
 * status, bytes }, from lines like `GET /models/spot.qm range=0-3062 -> 206 3063`.
 */
export function requests(log, urlPath) {
  const out = [];
  for (const line of log) {
    const m = /^(GET|HEAD) (\S+) range=(\S+) -> (\d{3}) (\d+)/.exec(line.trim());
    if (m && m[2] === urlPath) out.push({ method: m[1], path: m[2], range: m[3], status: Number(m[4]), bytes: Number(m[5]) });
  }
  return out;
}

/** Whether this `qm serve` logs requests in that form (the Range-capable server). */
export function logsRequests(log) {
  return log.some((line) => /^(GET|HEAD) \S+ range=\S+ -> \d{3} \d+/.test(line.trim()));
}

/** Headless Chromium from the Debian package, with a fresh profile. */
export async function browser({ width = 640, height = 480 } = {}) {
  const executablePath = process.env.CHROMIUM ?? execSync('which chromium', { encoding: 'utf8' }).trim();
  const profile = scratch('profile');
  const context = await chromium.launchPersistentContext(profile, {
    executablePath,
    headless: true,
    viewport: { width, height },
    args: [
      '--headless',
      '--no-sandbox',
      '--disable-gpu',
      '--disable-quic',
      '--no-first-run',
      '--disable-background-networking',
      '--disable-component-update',
      '--disable-sync',
      // WebGL without a GPU: ANGLE on SwiftShader.
      '--use-angle=swiftshader',
      '--enable-unsafe-swiftshader',
    ],
  });
  const page = context.pages()[0] ?? (await context.newPage());
  const errors = [];
  page.on('pageerror', (e) => errors.push(String(e)));
  page.on('console', (m) => {
    if (m.type() === 'error') errors.push(m.text());
  });
  return {
    page,
    context,
    errors,
    close: async () => {
      await context.close();
      fs.rmSync(profile, { recursive: true, force: true });
    },
  };
}
