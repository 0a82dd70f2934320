// Runs the packages' tests against their packed tarballs, installed as a user
// would install them:
//   1. a clean folder with only `npm install --offline qm-decoder-*.tgz`
//      (no dependencies: it must install without the network), where the
//      Node tests (test/node/*.test.mjs, copied there) run with `node --test`;
//   2. a clean folder with both tarballs and three, where the browser test
//      pages (test/browser/pages/*.js) are bundled with esbuild into www/;
//      test/browser/*.test.mjs then drive them in headless Chromium;
//   3. in that folder, `tsc --noEmit --strict` of test/types/check.ts, a
//      use of both packages' declarations (with @types/three).
// Needs `js/build.sh` (the tarballs in $CARGO_TARGET_DIR/js) and release
// builds of qm and the qm-wasm examples; `.ci/web` does both.
//
//   node test/run.mjs [node|browser|types]...   (default: all)

import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import * as esbuild from 'esbuild';
import { bins, js, out, root } from './harness.mjs';

const which = process.argv.slice(2);
const run = (name) => which.length === 0 || which.includes(name);

function tarball(name) {
  const file = fs.readdirSync(out).find((f) => f.startsWith(`${name}-`) && f.endsWith('.tgz'));
  if (!file) {
    console.error(`error: no ${name}-*.tgz in ${out}: run js/build.sh first`);
    process.exit(1);
  }
  return path.join(out, file);
}

function cleanFolder(name) {
  const dir = path.join(out, name);
  fs.rmSync(dir, { recursive: true, force: true });
  fs.mkdirSync(dir, { recursive: true });
  fs.writeFileSync(path.join(dir, 'package.json'), JSON.stringify({ name: `qm-${name}`, private: true, type: 'module' }, null, 2));
  return dir;
}

function npm(dir, args) {
  execFileSync('npm', [...args, '--no-audit', '--no-fund', '--loglevel=error'], { cwd: dir, stdio: 'inherit' });
}

for (const bin of [bins.qm, bins.reference, bins.coloured]) {
  if (!fs.existsSync(bin)) {
    console.error(`error: ${bin} is missing: cargo build --release -p qm-cli -p qm-wasm --bins --examples`);
    process.exit(1);
  }
}

let failed = false;

if (run('node')) {
  const dir = cleanFolder('clean-node');
  npm(dir, ['install', '--offline', tarball('qm-decoder')]);
  const tests = path.join(js, 'test', 'node');
  for (const f of fs.readdirSync(tests)) fs.copyFileSync(path.join(tests, f), path.join(dir, f));
  const scratch = fs.mkdtempSync(path.join(out, 'node-scratch-'));
  const r = spawnSync(process.execPath, ['--test', '--test-concurrency=1', ...fs.readdirSync(tests).filter((f) => f.endsWith('.test.mjs'))], {
    cwd: dir,
    stdio: 'inherit',
    env: { ...process.env, QM_ROOT: root, QM_BIN: bins.qm, QM_REFERENCE: bins.reference, QM_COLOURED: bins.coloured, QM_SCRATCH: scratch },
  });
  fs.rmSync(scratch, { recursive: true, force: true });
  if (r.status !== 0) failed = true;
}

if (run('browser')) {
  const dir = cleanFolder('clean-web');
  const three = JSON.parse(fs.readFileSync(path.join(js, 'node_modules', 'three', 'package.json'), 'utf8')).version;
  npm(dir, ['install', '--prefer-offline', tarball('qm-decoder'), tarball('three-qm-loader'), `three@${three}`]);
  const pages = path.join(js, 'test', 'browser', 'pages');
  const www = path.join(dir, 'www');
  fs.mkdirSync(www);
  for (const f of fs.readdirSync(pages)) {
    fs.copyFileSync(path.join(pages, f), path.join(dir, f));
    if (f.endsWith('.html')) fs.copyFileSync(path.join(pages, f), path.join(www, f));
  }
  // For setDecoderPath: the wasm file the package ships.
  fs.mkdirSync(path.join(www, 'libs'));
  fs.copyFileSync(path.join(dir, 'node_modules', 'three-qm-loader', 'dist', 'qm_decoder_bg.wasm'), path.join(www, 'libs', 'qm_decoder_bg.wasm'));
  // qm serve --web wants an index.html.
  fs.copyFileSync(path.join(pages, 'loader.html'), path.join(www, 'index.html'));
  // Bundled from the clean folder, so that the bare imports resolve to the
  // installed packages. The decoder's inlined wasm is a separate chunk.
  await esbuild.build({
    entryPoints: fs.readdirSync(pages).filter((f) => f.endsWith('.js')).map((f) => path.join(dir, f)),
    bundle: true,
    splitting: true,
    format: 'esm',
    target: 'es2022',
    outdir: www,
    absWorkingDir: dir,
    logLevel: 'warning',
  });
  const browserTests = path.join(js, 'test', 'browser');
  const files = fs.readdirSync(browserTests).filter((f) => f.endsWith('.test.mjs')).map((f) => path.join(browserTests, f));
  const r = spawnSync(process.execPath, ['--test', '--test-concurrency=1', ...files], {
    cwd: js,
    stdio: 'inherit',
    env: { ...process.env, QM_WWW: www },
  });
  if (r.status !== 0) failed = true;
}

if (run('types')) {
  const dir = path.join(out, 'clean-web');
  if (!fs.existsSync(path.join(dir, 'node_modules', 'three-qm-loader'))) {
    console.error('error: the types check needs the browser step first (node test/run.mjs browser types)');
    process.exit(1);
  }
  const types = JSON.parse(fs.readFileSync(path.join(js, 'node_modules', '@types', 'three', 'package.json'), 'utf8')).version;
  npm(dir, ['install', '--prefer-offline', '--no-save', `@types/three@${types}`]);
  fs.copyFileSync(path.join(js, 'test', 'types', 'check.ts'), path.join(dir, 'check.ts'));
  const tsc = path.join(js, 'node_modules', 'typescript', 'bin', 'tsc');
  const r = spawnSync(process.execPath, [tsc, '--noEmit', '--strict', '--skipLibCheck', 'false', '--target', 'es2022', '--module', 'nodenext', '--moduleResolution', 'nodenext', '--lib', 'es2022,dom', 'check.ts'], { cwd: dir, stdio: 'inherit' });
  if (r.status === 0) console.log('# types: tsc --strict accepts both packages\' declarations');
  else failed = true;
}

process.exit(failed ? 1 : 0);
