#!/usr/bin/env python3
"""Parts per hour of the Dask example against the command line's batch, on one folder.

    python crates/moldgate-py/bench/batch.py [DIR] [--rounds 3]

Per round, in turn: ``moldgate locate DIR --summary out.jsonl`` (whole command), then the
Dask example's ``run`` on a ``LocalCluster(n_workers=2, processes=True,
threads_per_worker=1)`` with ``RAYON_NUM_THREADS=1`` (the cluster is started once,
before the rounds, and its start is timed apart). Medians; the machine's load average is
printed with them.
"""

import argparse
import importlib.util
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[3]
HERE = pathlib.Path(__file__).resolve().parents[1]
DEFAULT = ROOT.parent / "shared" / "data" / "parts"
if not DEFAULT.is_dir():
    DEFAULT = pathlib.Path("/work/shared/data/parts")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", nargs="?", default=str(DEFAULT))
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--cli", default=os.environ.get("MOLDGATE_CLI"))
    a = ap.parse_args()
    cli = a.cli or str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "moldgate")
    spec = importlib.util.spec_from_file_location("dask_batch", HERE / "examples" / "dask_batch.py")
    ex = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ex)
    from dask.distributed import Client

    parts = [(f, None, None) for f in ex.expand([a.folder])]
    n = len(parts)
    t = time.perf_counter()
    cluster = ex.local_cluster(workers=2, rayon_threads=1)
    client = Client(cluster)
    start_s = time.perf_counter() - t
    t_cli, t_dask = [], []
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "out.jsonl")
        for _ in range(a.rounds):
            t = time.perf_counter()
            subprocess.run([cli, "locate", a.folder, "--summary", out, "--quiet"],
                           stdout=subprocess.DEVNULL, check=False)
            t_cli.append(time.perf_counter() - t)
            t = time.perf_counter()
            ex.run(client, parts, {})
            t_dask.append(time.perf_counter() - t)
    client.close()
    cluster.close()
    med = statistics.median
    load = os.getloadavg()
    print(f"{n} parts in {a.folder}; {os.cpu_count()} cores; load average "
          f"{load[0]:.1f} {load[1]:.1f} {load[2]:.1f}; {a.rounds} rounds interleaved")
    print(f"CLI batch (moldgate locate DIR --summary): median {med(t_cli):.2f} s = "
          f"{n / med(t_cli) * 3600:,.0f} parts/hour")
    print(f"Dask example, 2 workers x 1 thread:        median {med(t_dask):.2f} s = "
          f"{n / med(t_dask) * 3600:,.0f} parts/hour (cluster start {start_s:.1f} s, not included)")


if __name__ == "__main__":
    sys.exit(main())
