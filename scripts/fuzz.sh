#!/usr/bin/env bash
# Runs each fuzz target of fuzz/ for a set time, one after the other (one core), and prints
# per target the executions and libFuzzer's coverage (cov: edges, ft: features) from its final
# stats. A crash ends that target, and the run exits 1 naming the input that caused it.
#
#   scripts/fuzz.sh SECONDS [TARGET...]     (default: 60 s, every target)
#
# Needs cargo-fuzz (`cargo install cargo-fuzz --version 0.13.1 --locked`); the nightly flags
# it passes are allowed on the stable toolchain by RUSTC_BOOTSTRAP=1. The seed corpus is made
# by `cargo run -p moldgate --example fuzz_seeds`; what libFuzzer finds goes to
# fuzz/corpus/TARGET (not committed), crashes to fuzz/artifacts/TARGET.
#
# FUZZ_SANITIZER (default none) is passed to cargo fuzz -s: the library has no unsafe code,
# and AddressSanitizer made the STL target 26 times slower (1.1k against 30k runs a second,
# docs/fuzzing.md) for no class of bug that safe Rust can have; `address` is there for
# runs that want it. FUZZ_SECONDS_ANALYSE overrides SECONDS for the whole-analysis target.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(read_stl read_obj read_ply analyse)
fi
export RUSTC_BOOTSTRAP=1
sanitizer=${FUZZ_SANITIZER:-none}
target_dir="${CARGO_TARGET_DIR:-$PWD/target}/fuzz"
seeds="$target_dir/seeds"
logs="$target_dir/logs"
mkdir -p "$logs"

cargo run --quiet --release -p moldgate --example fuzz_seeds -- "$seeds"
(cd fuzz && cargo fuzz build -O -s "$sanitizer" --target-dir "$target_dir")

printf '%-9s %8s %12s %10s %7s %7s %7s\n' target seconds executions "exec/s" cov ft corpus
status=0
for t in "${targets[@]}"; do
    corpus="fuzz/corpus/$t"
    mkdir -p "$corpus" "fuzz/artifacts/$t"
    # Small inputs: a part of a few hundred triangles is enough to reach every reader
    # branch, and keeps the whole analysis at thousands of runs a second.
    max_len=8192
    [ "$t" = analyse ] && max_len=4096
    time_s=$seconds
    [ "$t" = analyse ] && time_s=${FUZZ_SECONDS_ANALYSE:-$seconds}
    log="$logs/$t.log"
    set +e
    (cd fuzz && cargo fuzz run -O -s "$sanitizer" --target-dir "$target_dir" "$t" \
        "corpus/$t" "$seeds/$t" -- \
        -max_total_time="$time_s" -max_len="$max_len" -timeout=20 -rss_limit_mb=4096 \
        -print_final_stats=1) >"$log" 2>&1
    rc=$?
    set -e
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
    done_line=$(grep -E '^#[0-9]+[[:space:]]+(DONE|pulse|NEW|REDUCE|INITED)' "$log" | tail -1 || true)
    cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$done_line")
    ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$done_line")
    size=$(find "$corpus" -type f | wc -l)
    rate=$(sed -n 's/.* exec\/s: \([0-9]*\).*/\1/p' <<<"$done_line")
    printf '%-9s %8s %12s %10s %7s %7s %7s\n' "$t" "$time_s" "${execs:--}" "${rate:--}" \
        "${cov:--}" "${ft:--}" "$size"
    if [ $rc -ne 0 ]; then
        status=1
        echo "$t: libFuzzer stopped with exit code $rc (log: $log):"
        grep -E 'panicked|ERROR: |SUMMARY|Test unit written to' "$log" | head -5 | sed 's/^/    /'
    fi
done
exit $status
