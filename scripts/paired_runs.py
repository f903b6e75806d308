#!/usr/bin/env python3
"""Paired timing of several moldgate binaries on one command: wall and CPU time.

    python3 scripts/paired_runs.py RUNS BINARY [BINARY ...] -- ARGS...

Each round runs `BINARY ARGS` once for every binary, in a random order (so the machine's
slow and fast phases fall on all alike), and measures its wall time and its CPU time (user
plus system, from the kernel's accounting of the child). Prints, per binary, the medians
and, against the first binary, the median of the per-round ratios of both. The CPU time
moves less than the wall time when the machine is shared: it does not count the time the
command waits for a core, only what it does (and the cache and memory contention of the
others). The load average is printed before and after.

Example (the choice of the demolding direction, old and new):

    python3 scripts/paired_runs.py 15 /tmp/old target/release/moldgate -- \\
        locate ../shared/data/parts/esp32s3box_bottom_housing_352k.stl --demold auto

Standard library only (Linux: os.wait4).
"""
import os
import random
import statistics
import subprocess
import sys
import time


def run(binary, args):
    """Wall and CPU seconds of one run."""
    start = time.perf_counter()
    with open(os.devnull, "wb") as null:
        child = subprocess.Popen([binary, *args], stdout=null, stderr=null)
        _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    if status != 0:
        sys.exit(f"{binary} {' '.join(args)}: exit status {status}")
    return wall, usage.ru_utime + usage.ru_stime


def main():
    if "--" not in sys.argv or sys.argv.index("--") < 3:
        sys.exit(__doc__)
    split = sys.argv.index("--")
    runs, bins, args = int(sys.argv[1]), sys.argv[2:split], sys.argv[split + 1:]
    print("load average before:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    times = {b: [] for b in bins}
    rng = random.Random(1)
    for _ in range(runs):
        order = list(bins)
        rng.shuffle(order)
        for b in order:
            times[b].append(run(b, args))
    print("load average after: ", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"{runs} rounds of: {' '.join(args)}")
    print("| binary | wall ms median | CPU ms median | wall / first (median of rounds) "
          "| CPU / first (median of rounds) |")
    print("|---|---:|---:|---:|---:|")
    first = times[bins[0]]
    for b in bins:
        t = times[b]
        wall = statistics.median(x[0] for x in t) * 1e3
        cpu = statistics.median(x[1] for x in t) * 1e3
        rw = statistics.median(x[0] / y[0] for x, y in zip(t, first))
        rc = statistics.median(x[1] / y[1] for x, y in zip(t, first))
        print(f"| {b} | {wall:.1f} | {cpu:.1f} | {rw:.3f} | {rc:.3f} |")


if __name__ == "__main__":
    main()
