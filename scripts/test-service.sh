#!/usr/bin/env bash
# Fuzzes `moldgate serve` from its own OpenAPI document with schemathesis (PyPI): every
# operation, positive and negative data, every response checked against the document
# (status codes, content types, schemas) and for server errors. Loopback only, bounded in
# examples per operation (100, schemathesis's default; with seed 1 the same cases every run)
# and not in time: under a time budget (`--max-time`) its fuzzing and stateful phases draw
# cases until the budget is spent, so the run would take that long on any machine and test
# less the busier the machine is. SCHEMATHESIS_MAX_TIME=600 gives a longer campaign.
#
#   scripts/test-service.sh            # the debug binary (built by cargo test), built if needed
#   MOLDGATE_BIN=path/to/moldgate scripts/test-service.sh
#   scripts/test-service.sh --setup    # only install schemathesis (scripts/test runs it
#                                      # while cargo compiles)
#
# Installs what it needs on a fresh machine: a virtualenv under the cargo target folder with
# a pinned schemathesis. Exit code: schemathesis's (non-zero on any failure), or 2 when the
# server does not start.
set -euo pipefail

cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-$PWD/target}"
bin="${MOLDGATE_BIN:-$target/debug/moldgate}"
venv="$target/schemathesis-venv"
schemathesis_version="4.32.5"
max_examples="${SCHEMATHESIS_MAX_EXAMPLES:-100}"
max_time="${SCHEMATHESIS_MAX_TIME-}"
start=$(date +%s)

if [ ! -x "$venv/bin/schemathesis" ] || ! "$venv/bin/schemathesis" --version | grep -q "$schemathesis_version"; then
  echo "test-service: installing schemathesis $schemathesis_version into $venv" >&2
  python3 -m venv "$venv"
  "$venv/bin/pip" install --quiet --disable-pip-version-check "schemathesis==$schemathesis_version"
fi
if [ "${1:-}" = "--setup" ]; then
  exit 0
fi
if [ ! -x "$bin" ]; then
  echo "test-service: building $bin" >&2
  cargo build -p moldgate-cli
fi

port=$("$venv/bin/python" -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
log="$target/test-service-server.log"
"$bin" serve --bind "127.0.0.1:$port" --timeout 20 --max-upload 8 2>"$log" &
server=$!
stop() { kill -TERM "$server" 2>/dev/null || true; wait "$server" 2>/dev/null || true; }
trap stop EXIT

base="http://127.0.0.1:$port"
for _ in $(seq 1 100); do
  if "$venv/bin/python" -c "import urllib.request,sys; urllib.request.urlopen('$base/healthz', timeout=1)" 2>/dev/null; then
    break
  fi
  if ! kill -0 "$server" 2>/dev/null; then
    echo "test-service: the server did not start:" >&2
    cat "$log" >&2
    exit 2
  fi
  sleep 0.1
done

# positive_data_acceptance is left out: a schema cannot say what a valid mesh is, so
# generated bodies that fit the schema are (rightly) refused with 422. Every other check
# runs, on every operation.
# It runs in the target folder, where it keeps its cache (.schemathesis/) and Hypothesis's.
status=0
(cd "$target" && "$venv/bin/schemathesis" run "$base/v1/openapi.json" \
  --checks all --exclude-checks positive_data_acceptance \
  --max-examples "$max_examples" ${max_time:+--max-time "$max_time"} --seed 1 \
  --request-timeout 30 --workers 2 --no-color \
  --report junit --report-dir "$target/schemathesis-report") || status=$?

if grep -q "internal error" "$log"; then
  echo "test-service: the server logged an internal error:" >&2
  grep "internal error" "$log" >&2
  status=1
fi
stop
trap - EXIT
echo "test-service: schemathesis exit $status, $(grep -c ' /' "$log" || true) requests served, $(( $(date +%s) - start )) s" >&2
exit "$status"
