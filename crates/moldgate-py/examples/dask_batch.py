"""moldgate over many parts with dask.distributed: JSON Lines rows identical to those of
``moldgate locate DIR --summary x.jsonl`` (the ``time_s`` column aside).

    pip install "./crates/moldgate-py[dask]"
    python crates/moldgate-py/examples/dask_batch.py PARTS_DIR --summary rows.jsonl
    python crates/moldgate-py/examples/dask_batch.py --manifest parts.toml --summary rows.jsonl \\
        --scheduler tcp://scheduler:8786 --material ABS

Inputs are expanded like the command line's: a file as given, a folder's ``.stl``,
``.obj`` and ``.ply`` files (any case, not in subfolders) sorted by name, and a manifest's
``[[part]]`` tables (``file`` relative to the manifest, optional ``units`` and
``demold``). Each part is one task; a part that fails is a failed row (its status and
reason), never a dead run, and a task that does not finish in ``--timeout`` seconds (a
part that exhausts a worker) is an ``internal_error`` row. Rows are written in input
order, whole or not at all.

Without ``--scheduler`` a ``LocalCluster`` of ``--workers`` processes with one thread each
is started. Each worker runs moldgate's parallel stages on ``RAYON_NUM_THREADS`` threads
(default 1: one part per core); the variable is set in the workers' environment before
moldgate starts its thread pool there.
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import sys
import tempfile
from typing import Iterable, List, Optional, Sequence, Tuple

MESH_EXTENSIONS = (".stl", ".obj", ".ply")


def expand(inputs: Iterable[str]) -> List[str]:
    """The parts in order, as the command line expands its inputs."""
    out: List[str] = []
    for given in inputs:
        if not os.path.isdir(given):
            out.append(given)
            continue
        found = sorted(
            os.path.join(given, name)
            for name in os.listdir(given)
            if name.lower().endswith(MESH_EXTENSIONS) and os.path.isfile(os.path.join(given, name))
        )
        if not found:
            raise SystemExit(f"{given}: is a folder holding no .stl, .obj or .ply file")
        out.extend(found)
    return out


def read_manifest(path: str) -> List[Tuple[str, Optional[str], Optional[str]]]:
    """A manifest's parts: (file, units or None, demold or None)."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11
        import tomli as tomllib
    with open(path, "rb") as f:
        manifest = tomllib.load(f)
    folder = os.path.dirname(path)
    return [
        (os.path.join(folder, p["file"]), p.get("units"), p.get("demold"))
        for p in manifest.get("part", [])
    ]


def study_row(path: str, units: str, demold: str, options: dict) -> dict:
    """One task: the summary row of one part (runs on a worker)."""
    import moldgate

    return moldgate.batch_row(path, units=units, demold=demold, **options)


def failed_row(path: str, units: str, demold: str, why: str) -> dict:
    """The row of a task that did not come back (a lost worker, a time-out)."""
    keys = ["triangles", "gate_x_mm", "gate_y_mm", "gate_z_mm", "distance_mm",
            "gate_radius_mm", "nodes", "circle_on_part", "qualifying", "warnings"]
    row = {"file": path, "status": "internal_error", "exit_code": 1, "units": units,
           "demold": demold}
    row.update({k: None for k in keys})
    row.update({"time_s": 0.0, "error": why})
    return row


def run(
    client,
    parts: Sequence[Tuple[str, Optional[str], Optional[str]]],
    options: dict,
    units: str = "mm",
    timeout_s: float = 600.0,
) -> List[dict]:
    """The rows of `parts` ((file, units, demold) with None for the defaults), in order.

    Options are checked once, here, before any task: refused options would fail every
    part (`moldgate.OptionsError`)."""
    import moldgate
    from dask.distributed import wait

    demold = options.get("demold", "+z")
    options = {k: v for k, v in options.items() if k != "demold"}
    # Fails here, on the client, for options every part would refuse.
    moldgate.check_options(demold=demold, **options)
    tasks = [(f, u or units, d or demold) for f, u, d in parts]
    futures = [
        client.submit(study_row, f, u, d, options, pure=False, key=f"moldgate-{i}")
        for i, (f, u, d) in enumerate(tasks)
    ]
    wait(futures, timeout=timeout_s, return_when="ALL_COMPLETED") if futures else None
    rows = []
    for (f, u, d), fut in zip(tasks, futures):
        if fut.status == "finished":
            rows.append(fut.result())
        elif fut.status == "error":
            rows.append(failed_row(f, u, d, f"the task failed: {fut.exception()}"))
        else:
            fut.cancel()
            rows.append(failed_row(f, u, d, f"no result within {timeout_s:g} s"))
    return rows


def write_rows(path: str, rows: Sequence[dict]) -> None:
    """JSON Lines, whole or not at all (a temporary file in the same folder, renamed)."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".moldgate-", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as out:
            for row in rows:
                out.write(json.dumps(row, separators=(",", ":")) + "\n")
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def local_cluster(workers: int, rayon_threads: int):
    """A LocalCluster of `workers` processes, one thread each, moldgate's pool sized."""
    from dask.distributed import LocalCluster

    return LocalCluster(
        n_workers=workers,
        processes=True,
        threads_per_worker=1,
        env={"RAYON_NUM_THREADS": str(rayon_threads)},
        dashboard_address=None,
    )


def main(argv: Optional[Sequence[str]] = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="*", help="mesh files and folders")
    p.add_argument("--manifest", help="a TOML manifest of [[part]] tables")
    p.add_argument("--summary", required=True, help="the JSON Lines file to write")
    p.add_argument("--scheduler", help="address of a running Dask scheduler")
    p.add_argument("--workers", type=int, default=2, help="local worker processes [2]")
    p.add_argument("--rayon-threads", type=int, default=1, help="moldgate threads per worker [1]")
    p.add_argument("--timeout", type=float, default=600.0, help="seconds for the whole batch")
    p.add_argument("--units", default="mm")
    p.add_argument("--demold", default="+z")
    p.add_argument("--material", default="PP")
    p.add_argument("--option", action="append", default=[], metavar="NAME=JSON",
                   help="any other study option, e.g. --option fill=true --option gates=2")
    a = p.parse_args(argv)
    parts = [(f, None, None) for f in expand(a.inputs)]
    if a.manifest:
        parts += read_manifest(a.manifest)
    if not parts:
        p.error("give mesh files, folders or --manifest")
    options = {"demold": a.demold, "material": a.material}
    for o in a.option:
        name, _, value = o.partition("=")
        options[name] = json.loads(value)

    from dask.distributed import Client

    cluster = None if a.scheduler else local_cluster(a.workers, a.rayon_threads)
    with Client(a.scheduler or cluster) as client:
        rows = run(client, parts, options, a.units, a.timeout)
    if cluster is not None:
        cluster.close()
    write_rows(a.summary, rows)
    failed = [r for r in rows if r["exit_code"] not in (0,)]
    for r in failed:
        print(f"moldgate: error: {r['file']}: {r['error']}", file=sys.stderr)
    ok = sum(r["exit_code"] == 0 for r in rows)
    print(f"{len(rows)} parts: {ok} with a gate, {len(failed)} without or failed; rows in {a.summary}")
    return 0 if not failed else 1


if __name__ == "__main__":
    sys.exit(main())
