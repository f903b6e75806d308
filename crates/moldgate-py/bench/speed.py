#!/usr/bin/env python3
"""Speed of the Python package against the command line and the Python reference, measured
interleaved in one run (medians).

Per round, in turn:
- the CLI's whole command, ``moldgate locate PART --demold D`` (process start to exit);
- ``moldgate.study(PART, demold=D)`` in this process (reading the file included);
- ``moldgate.study(mesh, demold=D)`` from a ``trimesh.Trimesh`` loaded beforehand;
- every ``--reference-every`` rounds, the reference (``gate_ref.py --engine trimesh
  --no-flow``, trimesh + Embree): its whole command, and its own load + locate time.

    pip install "./crates/moldgate-py" trimesh embreex scipy rtree
    cargo build --release -p moldgate-cli
    python crates/moldgate-py/bench/speed.py [PART] [--demold +y] [--rounds 15]

The trimesh figure also reports the peak of numpy's allocations during the call
(tracemalloc): numpy reports its allocations to tracemalloc, so a copy of the arrays on
the Python side would show as at least the smaller array's size.
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import time
import tracemalloc

import moldgate

ROOT = pathlib.Path(__file__).resolve().parents[3]
SHARED = ROOT.parent / "shared"
if not SHARED.is_dir():
    SHARED = pathlib.Path("/work/shared")
PART = SHARED / "data" / "parts" / "esp32s3box_bottom_housing_352k.stl"
REFERENCE = SHARED / "reference" / "gate_ref.py"
AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", nargs="?", default=str(PART))
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--reference-every", type=int, default=3)
    ap.add_argument("--cli", default=os.environ.get("MOLDGATE_CLI"))
    a = ap.parse_args()
    cli = a.cli or str(pathlib.Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target")) / "release" / "moldgate")
    if not os.path.exists(a.part):
        sys.exit(f"part not found: {a.part}")
    if not os.path.exists(cli):
        sys.exit(f"build the binary first (cargo build --release -p moldgate-cli), or pass --cli: {cli}")
    try:
        import trimesh

        mesh = trimesh.load(a.part, force="mesh")
    except ImportError:
        mesh = None
        print("trimesh is not installed: the trimesh figure is skipped")
    sign = -1 if a.demold.startswith("-") else 1
    d = [str(sign * c) for c in AXES[a.demold.lstrip("+-")]]
    ref_cmd = [sys.executable, str(REFERENCE), a.part, "--engine", "trimesh", "--no-flow", "--dir", *d]
    probe = subprocess.run([sys.executable, "-c", "import trimesh, embreex, scipy"], capture_output=True)
    use_ref = REFERENCE.exists() and probe.returncode == 0
    if not use_ref:
        print("reference: skipped (needs ../shared/reference and trimesh, embreex, scipy)")

    cli_cmd = [cli, "locate", a.part, "--demold", a.demold]
    run_cli = lambda: subprocess.run(cli_cmd, check=True, stdout=subprocess.DEVNULL)  # noqa: E731
    # Warm the page cache, the allocator and the thread pools of both.
    run_cli()
    moldgate.study(a.part, demold=a.demold)
    if mesh is not None:
        moldgate.study(mesh, demold=a.demold)

    t_cli, t_py, t_tri, t_ref, t_ref_inner = [], [], [], [], []
    same = True
    for i in range(a.rounds):
        t_cli.append(timed(run_cli)[0])
        dt, s = timed(lambda: moldgate.study(a.part, demold=a.demold))
        t_py.append(dt)
        if mesh is not None:
            dt, s2 = timed(lambda: moldgate.study(mesh, demold=a.demold))
            t_tri.append(dt)
            same &= s2.report["gate"] == s.report["gate"]
        if use_ref and i % a.reference_every == 0:
            dt, r = timed(lambda: subprocess.run(ref_cmd, check=True, capture_output=True, text=True))
            t_ref.append(dt)
            import json

            t_ref_inner.append(json.loads(r.stdout)["timings_s"]["total"])

    med = statistics.median
    load = os.getloadavg()
    print(f"part: {os.path.basename(a.part)}, demold {a.demold}, {os.cpu_count()} cores, "
          f"load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}, {a.rounds} rounds interleaved")
    print(f"CLI whole command:          median {med(t_cli) * 1e3:7.1f} ms")
    print(f"moldgate.study(path):       median {med(t_py) * 1e3:7.1f} ms  "
          f"({med(t_py) / med(t_cli):.2f} x the CLI; the goal is at most 1.15)")
    if t_tri:
        tracemalloc.start()
        moldgate.study(mesh, demold=a.demold)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        smaller = min(mesh.vertices.nbytes, mesh.faces.nbytes)
        print(f"moldgate.study(trimesh):    median {med(t_tri) * 1e3:7.1f} ms  "
              f"(same gate as from the file: {same}; numpy allocations peak {peak / 1024:.0f} KiB "
              f"against {smaller / 1024:.0f} KiB for the smaller array)")
    if t_ref:
        print(f"reference whole command:    median {med(t_ref) * 1e3:7.1f} ms over {len(t_ref)} runs "
              f"(its load + locate: {med(t_ref_inner) * 1e3:.1f} ms)")
        print(f"moldgate.study(path) is {med(t_ref_inner) / med(t_py):.1f} times faster than the "
              f"reference's load + locate ({med(t_ref) / med(t_py):.1f} times its whole command)")


if __name__ == "__main__":
    main()
