"""The Dask example on a LocalCluster: its rows are the command line's batch rows."""

import importlib.util
import json
import pathlib

import pytest

from conftest import run_cli

pytest.importorskip("dask.distributed", reason='dask is not installed (pip install "dask[distributed]")')

EXAMPLE = pathlib.Path(__file__).resolve().parents[1] / "examples" / "dask_batch.py"


def example():
    spec = importlib.util.spec_from_file_location("dask_batch", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def rows_without_times(rows):
    return [{k: v for k, v in r.items() if k != "time_s"} for r in rows]


def test_dask_rows_equal_the_cli_batch_rows(parts_dir, cli, tmp_path):
    from dask.distributed import Client

    bad = tmp_path / "broken.stl"
    bad.write_bytes(b"\x00" * 90)  # a binary STL whose size does not match its count
    missing = tmp_path / "missing.ply"
    inputs = [str(parts_dir), str(bad), str(missing)]
    cli_rows_file = tmp_path / "cli.jsonl"
    run_cli(cli, "locate", *inputs, "--material", "ABS", "--summary", cli_rows_file, check=False)
    expected = [json.loads(line) for line in cli_rows_file.read_text().splitlines()]

    ex = example()
    parts = [(f, None, None) for f in ex.expand(inputs)]
    with ex.local_cluster(workers=2, rayon_threads=1) as cluster, Client(cluster) as client:
        assert client.run(lambda: __import__("os").environ["RAYON_NUM_THREADS"]) == {
            w: "1" for w in client.scheduler_info()["workers"]
        }
        rows = ex.run(client, parts, {"material": "ABS"})
    out = tmp_path / "dask.jsonl"
    ex.write_rows(str(out), rows)
    written = [json.loads(line) for line in out.read_text().splitlines()]
    assert written == rows
    assert rows_without_times(rows) == rows_without_times(expected)
    assert len(rows) == len(list(parts_dir.glob("*.[sS][tT][lL]"))) + 2
    assert [r["status"] for r in rows[-2:]] == ["input_error", "input_error"]
    assert any(r["status"] == "ok" for r in rows)
    assert not any(r["status"] == "internal_error" for r in rows)


def test_a_manifest_gives_each_part_its_unit_and_direction(parts_dir, cli, tmp_path):
    from dask.distributed import Client

    manifest = tmp_path / "parts.toml"
    manifest.write_text(
        f'[[part]]\nfile = "{parts_dir / "trimesh_ADIS16480_meters_ascii.STL"}"\nunits = "m"\ndemold = "+y"\n'
        f'[[part]]\nfile = "{parts_dir / "prusa_lcd_knob.stl"}"\n'
        f'[[part]]\nfile = "{parts_dir / "watchy_yatari_bottom.stl"}"\ndemold = "-z"\n'
    )
    summary = tmp_path / "cli.jsonl"
    run_cli(cli, "locate", "--manifest", manifest, "--summary", summary, check=False)
    expected = [json.loads(line) for line in summary.read_text().splitlines()]
    ex = example()
    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        rows = ex.run(client, ex.read_manifest(str(manifest)), {})
    assert rows_without_times(rows) == rows_without_times(expected)
    assert [r["units"] for r in rows] == ["m", "mm", "mm"]
    assert [r["demold"] for r in rows] == ["+y", "+z", "-z"]


def test_bad_options_stop_the_batch_before_any_task(tmp_path):
    from dask.distributed import Client

    import moldgate

    ex = example()
    with Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        with pytest.raises(moldgate.OptionsError, match="unknown field `gatez`"):
            ex.run(client, [("x.stl", None, None)], {"gatez": 2})
