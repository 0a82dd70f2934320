#!/usr/bin/env bash
# Builds the npm packages qm-decoder and three-qm-loader into js/*/dist and
# packs them (npm pack) into $CARGO_TARGET_DIR/js/: the qm-wasm crate for
# wasm32-unknown-unknown (release), its bindings (wasm-bindgen --target web),
# wasm-opt when it is installed, then build.mjs (inlined wasm, the worker
# bundle, the loader bundle, the declarations).
#
# Needs: rustup target add wasm32-unknown-unknown; cargo install
# wasm-bindgen-cli --version <the wasm-bindgen version in Cargo.lock>; npm;
# optionally binaryen (wasm-opt). .ci/web installs them.
set -euo pipefail
js="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$js")"
target="${CARGO_TARGET_DIR:-$root/target}"
out="$target/js"
cd "$root"
cargo build -p qm-wasm --release --target wasm32-unknown-unknown
mkdir -p "$out/wasm"
wasm-bindgen --target web --out-dir "$out/wasm" --out-name qm_decoder --no-typescript \
  "$target/wasm32-unknown-unknown/release/qm_wasm.wasm"
if command -v wasm-opt >/dev/null 2>&1; then
  # -O3: decode speed first; the size is measured in docs/js.md.
  wasm-opt -O3 --enable-bulk-memory --enable-sign-ext --enable-nontrapping-float-to-int \
    --enable-mutable-globals --enable-multivalue --enable-reference-types \
    "$out/wasm/qm_decoder_bg.wasm" -o "$out/wasm/qm_decoder_bg.opt.wasm"
  mv "$out/wasm/qm_decoder_bg.opt.wasm" "$out/wasm/qm_decoder_bg.wasm"
else
  echo "note: wasm-opt (binaryen) not found; the wasm is not optimized further" >&2
fi
cd "$js"
if [ ! -d node_modules ]; then
  npm ci --no-audit --no-fund
fi
node build.mjs "$out/wasm"
rm -f "$out"/qm-decoder-*.tgz "$out"/three-qm-loader-*.tgz
(cd qm-decoder && npm pack --silent --pack-destination "$out" >/dev/null)
(cd three-qm-loader && npm pack --silent --pack-destination "$out" >/dev/null)
ls -l "$out"/*.tgz
