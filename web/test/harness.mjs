// Shared helpers of the browser test and the measurement script: the qm
// binaries, `qm serve`, and headless Chromium through playwright-core.

import { execFileSync, execSync, spawn } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { chromium } from 'playwright-core';

export const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '../..');
const target = process.env.CARGO_TARGET_DIR
  ? path.resolve(root, process.env.CARGO_TARGET_DIR)
  : path.join(root, 'target');

// Release builds: `cargo build --release -p qm-cli -p qm-wasm --bins --examples` (web/build.sh does not).
export const bins = {
  qm: process.env.QM_BIN ?? path.join(target, 'release', 'qm'),
  reference: path.join(target, 'release', 'examples', 'reference'),
  bench: path.join(target, 'release', 'examples', 'bench'),
  coloured: path.join(target, 'release', 'examples', 'coloured'),
};

export function scratch(name) {
  return fs.mkdtempSync(path.join(os.tmpdir(), `qm-web-${name}-`));
}

/** Compresses `input` (relative to the repository) into `output`. */
export function compress(input, output) {
  execFileSync(bins.qm, ['compress', path.join(root, input), '-o', output, '--quiet'], { stdio: 'inherit' });
  return fs.readFileSync(output);
}

/** One JSON line from the native reference decoder. */
export function reference(file, bytes, level) {
  const args = [file, String(bytes)];
  if (level !== undefined) args.push(String(level));
  return JSON.parse(execFileSync(bins.reference, args, { encoding: 'utf8' }));
}

/** Starts `qm serve` on a free port; resolves to { url, stop }. */
export function serve(file, { throttle } = {}) {
  const args = ['serve', file, '--port', '0', '--quiet'];
  if (throttle) args.push('--throttle', String(throttle));
  const child = spawn(bins.qm, args, { stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolve, reject) => {
    let out = '';
    child.stdout.on('data', (d) => {
      out += d;
      const line = out.split('\n')[0];
      if (out.includes('\n')) {
        resolve({ url: line.trim(), stop: () => child.kill() });
      }
    });
    child.on('exit', (code) => reject(new Error(`qm serve exited with ${code}`)));
    child.on('error', reject);
  });
}

/** Headless Chromium from the Debian package, with a fresh profile. */
export async function browser({ width = 960, height = 600 } = {}) {
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
    errors,
    close: async () => {
      await context.close();
      fs.rmSync(profile, { recursive: true, force: true });
    },
  };
}
