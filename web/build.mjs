// Bundles the page into dist/: main.js (the viewer, three.js and the
// wasm-bindgen glue), style.css, index.html and the WebAssembly module that
// web/build.sh put into pkg/. The glue loads qm_wasm_bg.wasm from beside
// main.js.

import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import * as esbuild from 'esbuild';

const web = path.dirname(fileURLToPath(import.meta.url));
const dist = path.join(web, 'dist');
const wasm = path.join(web, 'pkg', 'qm_wasm_bg.wasm');
if (!fs.existsSync(wasm)) {
  console.error(`error: ${wasm} is missing: run web/build.sh (it builds the WebAssembly module first)`);
  process.exit(1);
}
fs.rmSync(dist, { recursive: true, force: true });
await esbuild.build({
  entryPoints: [path.join(web, 'src', 'main.js'), path.join(web, 'src', 'style.css')],
  bundle: true,
  format: 'esm',
  target: 'es2022',
  minify: true,
  outdir: dist,
  logLevel: 'warning',
});
fs.copyFileSync(wasm, path.join(dist, 'qm_wasm_bg.wasm'));
const html = fs
  .readFileSync(path.join(web, 'index.html'), 'utf8')
  .replace('./src/main.js', './main.js')
  .replace('./src/style.css', './style.css');
fs.writeFileSync(path.join(dist, 'index.html'), html);
for (const f of fs.readdirSync(dist)) {
  console.log(`dist/${f}: ${fs.statSync(path.join(dist, f)).size} bytes`);
}
