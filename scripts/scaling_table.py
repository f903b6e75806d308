#!/usr/bin/env python3
"""How `moldgate locate` grows with the part: time and peak memory against triangles.

Writes COPIES copies of the shared 352k part side by side into one binary STL
(crates/moldgate/examples/tiled_part.rs), for each count in --copies (default up to 23
copies, 8.1 million triangles, 405 MB), times the whole command on it (median of --runs),
takes the peak resident memory of each run from the kernel's accounting of the child
(wait4), deletes the file, and prints a Markdown table: triangles, file size, median time,
time per million triangles, peak resident memory and its ratio to the file's size. The load
average is printed before and after.

    cargo build --release -p moldgate-cli
    cargo build --release -p moldgate --example tiled_part
    python3 scripts/scaling_table.py [--copies 1,2,4,8,16,23] [--runs 3] [--dir /tmp]
        [--binary target/release/moldgate] [--tiler target/release/examples/tiled_part]
        [--demold auto] [--with="--fill"]

Plain `locate` by default; `--with=...` adds options to the command (one string, split as a
shell would, written with `=` as it starts with dashes), so that every analysis gets its
table: `--with="--fill"`, `--with="--wall-thickness"`, `--with="--gates 3"`,
`--with="--png {dir}/part.png"` (`{dir}` is the folder of the tiled files, emptied after
each size), and `--demold auto` for the automatic direction.

Standard library only.
"""

import argparse
import json
import os
import shlex
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


def run(cmd):
    """Wall seconds, peak resident KiB and stdout of one run of `cmd`."""
    start = time.perf_counter()
    with tempfile.TemporaryFile(mode="w+") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, text=True)
        out = proc.stdout.read()
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.perf_counter() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            sys.exit(f"{' '.join(cmd)} exited with {proc.returncode}: {err.read().strip()}")
    return seconds, usage.ru_maxrss, out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", default=DEFAULT_PART)
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--copies", default="1,2,4,8,16,23")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--dir", default=None, help="where the large files are written")
    ap.add_argument("--binary", default=os.path.join(TARGET, "release", "moldgate"))
    ap.add_argument("--tiler", default=os.path.join(TARGET, "release", "examples", "tiled_part"))
    ap.add_argument("--with", dest="extra", default="",
                    help="options added to the command, e.g. \"--fill\" ({dir}: the folder of the files)")
    args = ap.parse_args()
    try:
        extra = shlex.split(args.extra)
    except ValueError as e:
        sys.exit(f"--with {args.extra!r}: {e}")
    if args.runs < 1:
        sys.exit(f"--runs {args.runs}: at least 1")
    try:
        counts = [int(c) for c in args.copies.split(",")]
    except ValueError:
        counts = []
    if not counts or min(counts) < 1:
        sys.exit(f"--copies {args.copies!r}: a list of counts of at least 1, such as 1,2,4")
    for path, build in ((args.binary, "cargo build --release -p moldgate-cli"),
                        (args.tiler, "cargo build --release -p moldgate --example tiled_part")):
        if not os.path.exists(path):
            sys.exit(f"{path} not found: {build} (or give its path)")
    if not os.path.exists(args.part):
        sys.exit(f"part not found: {args.part}")
    if args.dir is not None and not os.path.isdir(args.dir):
        sys.exit(f"--dir {args.dir}: not a folder (make it first)")

    folder = tempfile.mkdtemp(prefix="moldgate-scaling-", dir=args.dir)
    extra = [a.replace("{dir}", folder) for a in extra]
    print(f"part: {os.path.basename(args.part)} tiled along x, demold {args.demold}"
          f"{', with ' + args.extra if args.extra else ''}, "
          f"{args.runs} runs each, {os.cpu_count()} cores")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    rows = []
    try:
        for copies in counts:
            path = os.path.join(folder, f"tiled_{copies}.stl")
            subprocess.run([args.tiler, args.part, path, str(copies)], check=True)
            size = os.path.getsize(path)
            cmd = [args.binary, "locate", path, "--demold", args.demold] + extra
            # The counts from the report; this run also brings the file into the page cache.
            report = json.loads(run(cmd + ["--json"])[2])
            results = [run(cmd) for _ in range(args.runs)]
            # The tiled file and whatever the command wrote there ({dir}).
            for name in os.listdir(folder):
                os.remove(os.path.join(folder, name))
            mesh = report["mesh"]
            rows.append((copies, mesh["triangles"], mesh.get("collapsed_facets", 0), size,
                         statistics.median(r[0] for r in results),
                         max(r[1] for r in results)))
    finally:
        for name in os.listdir(folder):
            os.remove(os.path.join(folder, name))
        os.rmdir(folder)
    print(f"load average after:  {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print()
    print("| copies | triangles | file MB | median ms | ms per M triangles | "
          "peak RSS MiB | peak RSS / file |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for copies, triangles, collapsed, size, seconds, rss_kib in rows:
        note = f" ({collapsed} collapsed)" if collapsed else ""
        print(f"| {copies} | {triangles:,}{note} | {size / 1e6:.1f} | {seconds * 1e3:.0f} | "
              f"{seconds * 1e3 / (triangles / 1e6):.0f} | {rss_kib / 1024:.1f} | "
              f"{rss_kib * 1024 / size:.2f} |")


if __name__ == "__main__":
    main()
