#!/usr/bin/env bash
# Builds the browser app into web/dist: the WebAssembly module of crates/moldgate-web, then the
# page with Vite. Installs what it needs on a fresh machine (the wasm32 target, the npm
# packages pinned by web/package-lock.json); `--setup` installs them and builds nothing.
# web/dist is one static folder with relative paths.
# wasm-opt (npm binaryen) is not used: measured, it took 2 minutes and saved 1.3 % of the
# gzipped size with no gain in speed (docs/web.md).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
target_dir=${CARGO_TARGET_DIR:-$root/target}

if ! rustup target list --installed | grep -qx wasm32-unknown-unknown; then
    echo "build-web: adding the wasm32-unknown-unknown target"
    rustup target add wasm32-unknown-unknown || {
        echo "build-web: cannot add the wasm32-unknown-unknown target (rustup target add failed)" >&2
        exit 1
    }
fi

# npm ci when node_modules is missing or older than the lock file.
if [ ! -f web/node_modules/.package-lock.json ] || [ web/package-lock.json -nt web/node_modules/.package-lock.json ]; then
    echo "build-web: npm ci --prefix web"
    npm ci --prefix web --no-audit --no-fund
fi
if [ "${1:-}" = "--setup" ]; then
    exit 0
fi

# The `wasm` profile is the module users get, and the one the browser tests run on;
# MOLDGATE_WASM_PROFILE builds another (e.g. `release`, for a debuggable module).
profile=${MOLDGATE_WASM_PROFILE:-wasm}
echo "build-web: cargo build -p moldgate-web --profile $profile --target wasm32-unknown-unknown"
cargo build -p moldgate-web --profile "$profile" --target wasm32-unknown-unknown
wasm=$target_dir/wasm32-unknown-unknown/$profile/moldgate_web.wasm

mkdir -p web/src/wasm
out=web/src/wasm/moldgate_web.wasm
cp "$wasm" "$out.tmp"
mv "$out.tmp" "$out"
echo "build-web: $(stat -c %s "$out") bytes of wasm ($(gzip -9c "$out" | wc -c) gzipped, $profile profile)"

echo "build-web: npm run build --prefix web"
npm run build --prefix web
echo "build-web: web/dist ready ($(du -sk web/dist | cut -f1) KiB)"
