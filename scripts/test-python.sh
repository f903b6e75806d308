#!/usr/bin/env bash
# Builds the Python package (crates/moldgate-py) into a virtual environment and runs its
# tests. The package and pytest must install or the script fails; each optional package
# (trimesh, dask[distributed], gmsh) that cannot be installed is named, and the tests that
# need it skip with the reason.
#
#   scripts/test-python.sh            # venv in target/py-venv (or $MOLDGATE_VENV)
#   scripts/test-python.sh -k step    # extra arguments go to pytest
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

pip install pytest numpy || fail "cannot install pytest and numpy"
# The test build is cargo's dev profile (the library optimised, as in every test build), so
# the extension module reuses what `cargo test` compiled in the same target folder instead
# of compiling the library again in release; MOLDGATE_PY_PROFILE=release tests the wheel as
# users get it (pyproject.toml).
profile=${MOLDGATE_PY_PROFILE:-dev}
echo "test-python: building ($profile profile) and installing ./crates/moldgate-py"
MATURIN_PEP517_ARGS="--profile $profile" CARGO_TARGET_DIR=$target pip install ./crates/moldgate-py \
    || fail "cannot build or install the moldgate package"

for optional in trimesh "dask[distributed]" gmsh; do
    if ! pip install "$optional"; then
        echo "test-python: could not install $optional; the tests that need it will skip"
    fi
done

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
