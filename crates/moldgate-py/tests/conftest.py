"""Shared fixtures: sample parts written as STL, the shared real parts, the CLI binary."""

import os
import pathlib
import shutil
import subprocess

import pytest

import moldgate

REPO = pathlib.Path(__file__).resolve().parents[3]
PARTS = pathlib.Path(os.environ.get("MOLDGATE_PARTS", REPO.parent / "shared" / "data" / "parts"))
if not PARTS.is_dir():
    PARTS = pathlib.Path("/work/shared/data/parts")


@pytest.fixture
def cover_stl(tmp_path):
    path = tmp_path / "cover.stl"
    path.write_bytes(moldgate.sample("cover").to_stl())
    return path


@pytest.fixture(scope="session")
def parts_dir():
    if not PARTS.is_dir():
        pytest.skip(f"the shared parts folder {PARTS} is absent")
    return PARTS


def _cli():
    given = os.environ.get("MOLDGATE_CLI")
    if given:
        return given
    for target in (os.environ.get("CARGO_TARGET_DIR"), str(REPO / "target")):
        if target:
            exe = pathlib.Path(target) / "release" / "moldgate"
            if exe.is_file():
                return str(exe)
    return shutil.which("moldgate")


@pytest.fixture(scope="session")
def cli():
    exe = _cli()
    if not exe:
        pytest.skip("the moldgate binary is not built (cargo build --release -p moldgate-cli, or set MOLDGATE_CLI)")
    return exe


def run_cli(cli, *args, check=True):
    r = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if check and r.returncode not in (0, 4):
        raise AssertionError(f"moldgate {' '.join(map(str, args))} exited {r.returncode}: {r.stderr}")
    return r


def without_timings(report):
    """A report without what varies from run to run: every `timings`, `times` and
    `time_s` entry, at any depth."""
    if isinstance(report, dict):
        return {k: without_timings(v) for k, v in report.items()
                if k not in ("timings", "times", "time_s")}
    if isinstance(report, list):
        return [without_timings(v) for v in report]
    return report
