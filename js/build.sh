#!/usr/bin/env bash
# Builds the npm packages qm-decoder and three-qm-loader into js/*/dist and
# packs them (npm pack) into $CARGO_TARGET_DIR/js/: the qm-wasm crate for
# wasm32-unknown-unknown (profile qm-js: release at opt-level "s" with LTO
# and one codegen unit: 73 KB gzipped against 79 KB at opt-level 3, and
# about 8% slower; see docs/js.md), its bindings (wasm-bindgen --target web), wasm-opt -O3
# (npm binaryen; it also drops the debug and producers sections), then
# build.mjs (inlined wasm, the worker
# bundle, the loader bundle, the declarations).
#
# Needs: rustup target add wasm32-unknown-unknown; cargo install
# wasm-bindgen-cli --version <the wasm-bindgen version in Cargo.lock>; npm.
# .ci/web installs them.
set -euo pipefail
js="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$js")"
target="${CARGO_TARGET_DIR:-$root/target}"
out="$target/js"
if [ ! -d "$js/node_modules" ]; then
  (cd "$js" && npm ci --no-audit --no-fund)
fi
cd "$root"
# The profile lives here, not in Cargo.toml: only the packages use it.
cargo build -p qm-wasm --target wasm32-unknown-unknown --profile qm-js \
  --config 'profile.qm-js.inherits="release"' --config 'profile.qm-js.lto=true' \
  --config 'profile.qm-js.codegen-units=1' --config 'profile.qm-js.debug=false' \
  --config 'profile.qm-js.opt-level="s"'
mkdir -p "$out/wasm"
wasm-bindgen --target web --out-dir "$out/wasm" --out-name qm_decoder --no-typescript \
  "$target/wasm32-unknown-unknown/qm-js/qm_wasm.wasm"
# -O3: decode speed first; the features are those rustc and wasm-bindgen
# use, which every current browser and Node 20 have. (Debian's binaryen 108
# breaks wasm-bindgen's externref table; the npm build is current.)
"$js/node_modules/.bin/wasm-opt" -O3 --enable-bulk-memory --enable-bulk-memory-opt \
  --enable-sign-ext --enable-nontrapping-float-to-int --enable-mutable-globals \
  --enable-reference-types --enable-multivalue --strip-debug --strip-producers \
  "$out/wasm/qm_decoder_bg.wasm" -o "$out/wasm/qm_decoder_bg.opt.wasm"
mv "$out/wasm/qm_decoder_bg.opt.wasm" "$out/wasm/qm_decoder_bg.wasm"
cd "$js"
node build.mjs "$out/wasm"
rm -f "$out"/qm-decoder-*.tgz "$out"/three-qm-loader-*.tgz
(cd qm-decoder && npm pack --silent --pack-destination "$out" >/dev/null)
(cd three-qm-loader && npm pack --silent --pack-destination "$out" >/dev/null)
ls -l "$out"/*.tgz
