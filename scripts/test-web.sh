#!/usr/bin/env bash
# The browser app's tests: on a fresh machine it installs what they need (the wasm32 target,
# Debian's chromium, the npm packages pinned in web/ and tools/gltf-validator), builds the
# command line (the reference answers; its test build) and the page, and runs the tests in
# headless Chromium with node's test runner. Exits non-zero when anything fails.
# `scripts/test-web.sh --setup` only installs (the same things) and builds nothing.
set -euo pipefail
cd "$(dirname "$0")/.."
target_dir=${CARGO_TARGET_DIR:-$PWD/target}

chromium=${CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$chromium" ]; then
    echo "test-web: installing Debian's chromium"
    apt-get install -y chromium || { apt-get update && apt-get install -y chromium; }
fi

if [ ! -f tools/gltf-validator/node_modules/.package-lock.json ] ||
    [ tools/gltf-validator/package-lock.json -nt tools/gltf-validator/node_modules/.package-lock.json ]; then
    echo "test-web: npm ci --prefix tools/gltf-validator"
    npm ci --prefix tools/gltf-validator --no-audit --no-fund
fi
# `--setup`: only what is installed (scripts/test runs it while cargo compiles).
if [ "${1:-}" = "--setup" ]; then
    exec scripts/build-web.sh --setup
fi

# The reference answers come from the test build of the command line (the library is
# optimised in it), not from a second, release build: $MOLDGATE_BIN (scripts/test passes the
# one `cargo test` built), else `cargo build -p moldgate-cli`.
bin=${MOLDGATE_BIN:-}
if [ -z "$bin" ]; then
    echo "test-web: cargo build -p moldgate-cli"
    cargo build -p moldgate-cli
    bin=$target_dir/debug/moldgate
fi

# The module users get: the `wasm` profile (Cargo.toml). scripts/test builds it (and the page)
# while the test build compiles, and says so with MOLDGATE_WEB_BUILT=1.
if [ "${MOLDGATE_WEB_BUILT:-}" != 1 ]; then
    scripts/build-web.sh
fi

cd web
MOLDGATE_BIN=$bin CHROMIUM=$chromium \
    node --test --test-concurrency=1 tests/glue.test.mjs tests/sight.test.mjs tests/app.test.mjs
