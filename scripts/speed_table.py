#!/usr/bin/env python3
"""The speed table: what each option costs, as a ratio to plain `moldgate locate`, in one run.

Every round runs each command once, in a random order (so the machine's slow and fast
phases fall on all of them alike), and the table gives, per command, the median whole-command
time and the median of its per-round ratio to plain locate in the same round:

    plain locate            moldgate locate PART --demold D
    --fill, --strategy balanced, --gates 3, --wall-thickness, --demold auto, --png FILE
    reference Embree rays   the Python reference's ray call (trimesh `intersects_first`,
                            Embree through embreex) with one ray per facet along its
                            inverted normal, as --wall-thickness casts: the call only,
                            timed inside a Python process that has already loaded the mesh
    parse floor             a streaming parse of the binary STL that only sums the
                            coordinates (crates/moldgate/examples/parse_floor.rs): the
                            least any command that reads the file can take

Each command's CPU time (user and system, all its threads) is given beside its wall time,
with its ratio to plain locate's in the same round: on a shared machine it moves less than
the wall time, and a change that only keeps the cores busier shows in the wall time alone.
The last line gives plain locate against the floor (the target is at most 6). The load
average is printed before and after. The reference row needs ../shared/reference's Python
dependencies (trimesh, embreex) in the Python given by --reference-python (default: this
one); without them it prints why it is left out.

    cargo build --release -p moldgate-cli
    cargo build --release -p moldgate --example parse_floor
    python3 scripts/speed_table.py [--runs 11] [--part PART.stl] [--demold +y]
        [--binary target/release/moldgate] [--floor target/release/examples/parse_floor]
        [--reference-python PYTHON] [--only=NAME,...] [--before BINARY] [--threads N]

(--only takes the rows' names, e.g. --only=--png or --only="--fill,--gates 3": with the
equals sign, since the names start with dashes.)

With --threads N, every moldgate command runs on N threads (RAYON_NUM_THREADS); with 1,
the ratios are those of the work itself (CPU time), which scheduling on more cores cannot
change.

With --before, every moldgate row is also run with that binary (the same rows, named
"... (before)", in the same shuffled rounds), its ratio taken to that binary's own plain
locate: a before / after table from one run.

Bad arguments (--runs or --threads below 1, a binary, floor or part that is not there, a
--before binary that is not there, an --only name that is no row) stop it before any run,
with one line on standard error and exit status 1 (argparse's own errors: status 2). A
--reference-python that does not run leaves the reference row out, saying why.

Standard library only.
"""

import argparse
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = next((p for p in (os.path.join(ROOT, *[".."] * up, "shared") for up in (1, 2))
               if os.path.isdir(p)), os.path.join(ROOT, "..", "shared"))
DEFAULT_PART = os.path.join(SHARED, "data", "parts", "esp32s3box_bottom_housing_352k.stl")
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))

# The reference's ray call, run in its own Python: load once (not timed), then time the
# Embree call for one ray per facet from just inside the facet along the inverted normal.
EMBREE = r"""
import sys, time
import numpy as np
import trimesh
mesh = trimesh.load(sys.argv[1], force="mesh")
assert type(mesh.ray).__module__.endswith("ray_pyembree"), type(mesh.ray).__module__
n = mesh.face_normals
o = mesh.triangles_center - n * (1e-6 * mesh.scale)
mesh.ray.intersects_first(o[:1000], -n[:1000])  # build the scene (not timed)
t = time.perf_counter()
hit = mesh.ray.intersects_first(o, -n)
print(time.perf_counter() - t, int((hit >= 0).sum()), len(hit))
"""


def loadavg():
    one, five, fifteen = os.getloadavg()
    return f"{one:.2f} {five:.2f} {fifteen:.2f}"


def timed(cmd, env=None):
    """The command's wall time and CPU time (user and system, of all its threads), s."""
    # getrusage counts in microseconds; os.times in clock ticks (10 ms here).
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    return wall, cpu


def embree_call(python, part):
    out = subprocess.run([python, "-c", EMBREE, part], check=True, capture_output=True,
                         text=True).stdout.split()
    return float(out[0])


def reference_reason(python):
    """Why the reference row cannot run, or None when it can."""
    if not os.path.isdir(os.path.join(SHARED, "reference")):
        return f"no reference folder at {os.path.join(SHARED, 'reference')}"
    try:
        probe = subprocess.run(
            [python, "-c", "import trimesh, embreex, numpy, scipy; "
             "import trimesh.ray.ray_pyembree"], capture_output=True, text=True)
    except OSError as e:
        return f"{python} does not run ({e.strerror})"
    if probe.returncode != 0:
        last = (probe.stderr.strip().splitlines() or ["?"])[-1]
        return f"{python} lacks the reference's dependencies ({last}); " \
               "pip install trimesh numpy scipy embreex rtree"
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default=DEFAULT_PART)
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--runs", type=int, default=11, help="rounds (default 11)")
    ap.add_argument("--binary", default=os.path.join(TARGET, "release", "moldgate"))
    ap.add_argument("--floor", default=os.path.join(TARGET, "release", "examples",
                                                    "parse_floor"))
    ap.add_argument("--reference-python", default=sys.executable)
    ap.add_argument("--only", help="comma-separated row names to run besides plain locate")
    ap.add_argument("--before", help="a second moldgate binary, run in the same rounds")
    ap.add_argument("--threads", type=int,
                    help="threads of every moldgate command (default: one per core)")
    args = ap.parse_args()
    if args.threads is not None and args.threads < 1:
        sys.exit(f"--threads must be at least 1, not {args.threads}")
    if args.runs < 1:
        sys.exit(f"--runs must be at least 1, not {args.runs}")
    env = None
    if args.threads is not None:
        env = dict(os.environ, RAYON_NUM_THREADS=str(args.threads))

    for path, build in ((args.binary, "cargo build --release -p moldgate-cli"),
                        (args.floor, "cargo build --release -p moldgate --example parse_floor")):
        if not os.path.exists(path):
            sys.exit(f"{path} not found: {build} (or give its path)")
    if args.before and not os.path.isfile(args.before):
        sys.exit(f"--before {args.before}: not found (a moldgate binary)")
    if not os.path.exists(args.part):
        sys.exit(f"part not found: {args.part}")

    png = os.path.join(tempfile.mkdtemp(prefix="speed-table-"), "part.png")

    def commands(binary):
        plain = [binary, "locate", args.part, "--demold", args.demold]
        return [
            ("plain locate", plain),
            ("--fill", plain + ["--fill"]),
            ("--strategy balanced", plain + ["--strategy", "balanced"]),
            ("--gates 3", plain + ["--gates", "3"]),
            ("--wall-thickness", plain + ["--wall-thickness"]),
            ("reference Embree rays", None),
            ("--demold auto", [binary, "locate", args.part, "--demold", "auto"]),
            ("--png", plain + ["--png", png]),
        ]

    def row(name, cmd):
        return (name, None if cmd is None else lambda: timed(cmd, env))

    rows = [row(name, cmd) for name, cmd in commands(args.binary)]
    rows.append(("parse floor", lambda: timed([args.floor, args.part])))
    if args.before:
        rows += [row(f"{name} (before)", cmd) for name, cmd in commands(args.before)
                 if cmd is not None]
    notes = []
    reason = reference_reason(args.reference_python)
    if reason is None:
        python = args.reference_python
        rows[5] = (rows[5][0], lambda: embree_call(python, args.part))
    else:
        notes.append(f"reference Embree rays: left out: {reason}")
        rows.pop(5)
    if args.only:
        keep = {"plain locate", *args.only.split(",")}
        known = {r[0] for r in rows} | {"reference Embree rays"}
        unknown = sorted(keep - known)
        if unknown:
            sys.exit(f"--only: no row named {', '.join(unknown)} "
                     f"(rows: {', '.join(r[0] for r in rows if not r[0].endswith(' (before)'))})")
        rows = [r for r in rows if r[0].removesuffix(" (before)") in keep]

    threads = ("" if args.threads is None else
               f", moldgate on {args.threads} thread{'' if args.threads == 1 else 's'}")
    print(f"part: {os.path.basename(args.part)}, demold {args.demold}; {args.runs} rounds, "
          f"{os.cpu_count()} cores{threads}; binary {args.binary}"
          + (f", before {args.before}" if args.before else ""))
    print(f"load average before: {loadavg()}")
    for _, run in rows:  # warm the page cache and the reference's imports
        run()
    times = {name: [] for name, _ in rows}
    rng = random.Random(1)
    cpu = {name: [] for name, _ in rows}
    for _ in range(args.runs):
        order = list(rows)
        rng.shuffle(order)
        for name, run in order:
            got = run()
            wall, used = got if isinstance(got, tuple) else (got, None)
            times[name].append(wall)
            cpu[name].append(used)
    print(f"load average after:  {loadavg()}")
    print()
    print("| command | median ms (min-max) | ratio to plain locate (median of rounds) "
          "| CPU ms (median) | CPU ratio (median of rounds) |")
    print("|---|---:|---:|---:|---:|")
    for name, _ in rows:
        t = times[name]
        base_name = "plain locate (before)" if name.endswith(" (before)") else "plain locate"
        base = times[base_name]
        ratio = statistics.median(x / y for x, y in zip(t, base))
        # The reference's call is timed inside its process: its CPU time is not known.
        if None in cpu[name]:
            cpu_cells = "- | -"
        else:
            cpu_ratio = statistics.median(x / y for x, y in zip(cpu[name], cpu[base_name]))
            cpu_cells = f"{statistics.median(cpu[name]) * 1e3:.1f} | {cpu_ratio:.2f}"
        print(f"| {name} | {statistics.median(t) * 1e3:.1f} ({min(t) * 1e3:.1f}-"
              f"{max(t) * 1e3:.1f}) | {ratio:.2f} | {cpu_cells} |")
    base = times["plain locate"]
    if "parse floor" in times:
        floor = times["parse floor"]
        ratio = statistics.median(x / y for x, y in zip(base, floor))
        print()
        print(f"plain locate / parse floor: {ratio:.2f} (median of rounds; target at most 6)")
    for note in notes:
        print(note)


if __name__ == "__main__":
    main()
