#!/usr/bin/env bash
# Builds the Python package (crates/moldgate-py) into a virtual environment and runs its
# tests. The package and pytest must install or the script fails; each optional package
# (trimesh, dask[distributed], gmsh) that cannot be installed is named, and the tests that
# need it skip with the reason.
#
#   scripts/test-python.sh            # venv in target/py-venv (or $MOLDGATE_VENV)
#   scripts/test-python.sh -k step    # extra arguments go to pytest
#   scripts/test-python.sh --setup    # only the venv and the packages from PyPI, no build
#                                     # (scripts/test runs it while cargo compiles)
set -uo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
venv=${MOLDGATE_VENV:-$repo/target/py-venv}
python=${PYTHON:-python3}
target=${CARGO_TARGET_DIR:-$repo/target}

fail() { echo "test-python: $*" >&2; exit 1; }

if [ ! -x "$venv/bin/python" ]; then
    echo "test-python: creating the virtual environment $venv"
    "$python" -m venv "$venv" || fail "cannot create a virtual environment with $python (on Debian: apt-get install python3-venv)"
fi
pip() { "$venv/bin/python" -m pip --disable-pip-version-check -q "$@"; }

# maturin (the build backend, at pyproject.toml's bounds) in the venv itself: the package's
# build below then skips pip's isolated build environment and its fresh install of maturin.
pip install pytest numpy "maturin>=1.9,<2" || fail "cannot install pytest, numpy and maturin"
for optional in trimesh "dask[distributed]" gmsh; do
    if ! pip install "$optional"; then
        echo "test-python: could not install $optional; the tests that need it will skip"
    fi
done
if [ "${1:-}" = "--setup" ]; then
    exit 0
fi

# The test build is cargo's dev profile (the library optimised, as in every test build), so
# the extension module reuses what `cargo test` compiled in the same target folder instead
# of compiling the library again in release; MOLDGATE_PY_PROFILE=release tests the wheel as
# users get it (pyproject.toml).
profile=${MOLDGATE_PY_PROFILE:-dev}
echo "test-python: building ($profile profile) and installing ./crates/moldgate-py"
build_log=$target/py-build.log
started=$target/py-build.started
mkdir -p "$target"
touch "$started"
# (The backend runs the `maturin` program of the venv: its bin folder goes first in PATH.)
if ! PATH=$venv/bin:$PATH MATURIN_PEP517_ARGS="--profile $profile" CARGO_TARGET_DIR=$target \
    pip install -v --no-build-isolation ./crates/moldgate-py >"$build_log" 2>&1; then
    tail -n 40 "$build_log" >&2
    fail "cannot build or install the moldgate package (whole log: $build_log)"
fi
# The dev build shares the library with `cargo test` only while the library's dependencies
# get the same features in both builds (crates/moldgate-py/Cargo.toml); say when they do not.
if [ "$profile" = dev ] && [ -n "$(find "$target/debug/deps" -name 'libmoldgate-*.rlib' -newer "$started" 2>/dev/null)" ] \
    && [ -n "$(find "$target/debug/deps" -name 'libmoldgate-*.rlib' ! -newer "$started" 2>/dev/null)" ]; then
    echo "test-python: the module's build compiled the library once more (see the features in crates/moldgate-py/Cargo.toml)"
fi

# The command-line binary, for the tests that compare the package with it: $MOLDGATE_CLI
# (scripts/test passes the one `cargo test` built), else the test build.
if [ -z "${MOLDGATE_CLI:-}" ]; then
    if cargo build -q -p moldgate-cli; then
        export MOLDGATE_CLI=$target/debug/moldgate
    else
        echo "test-python: the moldgate binary did not build; the comparisons with it will skip"
    fi
fi

cd crates/moldgate-py
"$venv/bin/python" -m pytest -q -rs tests "$@"
status=$?
if [ "$status" -eq 5 ]; then
    fail "pytest collected no test"
fi
exit "$status"
