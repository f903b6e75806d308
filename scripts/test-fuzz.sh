#!/usr/bin/env bash
# A smoke run of each fuzz target, a few seconds each (the campaign is scripts/fuzz.sh with a
# longer time, docs/fuzzing.md). cargo-fuzz is installed at a pinned version when missing; a
# tool that cannot be installed skips the run with a line, a crash found fails it.
set -euo pipefail
cd "$(dirname "$0")/.."
fuzz_version=0.13.1
if cargo fuzz --version 2>/dev/null | grep -q "$fuzz_version" \
    || cargo install cargo-fuzz --version "$fuzz_version" --locked; then
    bash scripts/fuzz.sh "${MOLDGATE_FUZZ_SECONDS:-5}"
else
    echo "cargo-fuzz $fuzz_version could not be installed: the fuzz smoke run is skipped"
fi
