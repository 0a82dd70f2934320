#!/usr/bin/env bash
# Builds the browser viewer into web/dist: the qm-wasm crate for
# wasm32-unknown-unknown, its JavaScript bindings (wasm-bindgen, into
# web/pkg), then the page (esbuild).
#
# Needs: rustup target add wasm32-unknown-unknown; cargo install
# wasm-bindgen-cli --version <the wasm-bindgen version in Cargo.lock>; npm.
set -euo pipefail
web="$(cd "$(dirname "$0")" && pwd)"
root="$(dirname "$web")"
target="${CARGO_TARGET_DIR:-$root/target}"
cd "$root"
cargo build -p qm-wasm --release --target wasm32-unknown-unknown
wasm-bindgen --target web --out-dir "$web/pkg" --no-typescript \
  "$target/wasm32-unknown-unknown/release/qm_wasm.wasm"
cd "$web"
if [ ! -d node_modules ]; then
  npm ci --no-audit --no-fund
fi
npm run --silent build
echo "built $web/dist ($(du -sh "$web/dist" | cut -f1)); serve it with: cargo run --release -- serve FILE.qm"
