#!/usr/bin/env python3
"""Whole-command times of the fill rows, as ratios to plain locate, for one or more binaries.

Each round runs, for every binary and in a random order, `locate PART --demold +y` with no
more options (plain), `--fill`, `--strategy balanced` and `--gates 3` on the shared 352k
part, so that the binaries and the rows share the machine's slow and fast phases. Prints
per binary and row the median time, and the median over the rounds of the ratio to the same
binary's plain locate of that round (paired), with the load average before and after;
then the same for the CPU time of each command (user + system, from `wait4`), which a busy
machine disturbs less than the wall time but which does not show work moved onto an idle
core.

    python3 scripts/fill_speed.py RUNS BINARY [BINARY ...]

Standard library only.
"""
import os
import random
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PART = next((p for p in (os.path.join(ROOT, *[".."] * up, "shared", "data", "parts",
                                      "esp32s3box_bottom_housing_352k.stl") for up in (1, 2))
             if os.path.exists(p)), None)
ROWS = {
    "plain": [],
    "--fill": ["--fill"],
    "--strategy balanced": ["--strategy", "balanced"],
    "--gates 3": ["--gates", "3"],
}


def main():
    if len(sys.argv) < 3 or PART is None:
        sys.exit("usage: fill_speed.py RUNS BINARY [BINARY ...] (needs the shared parts)")
    runs, bins = int(sys.argv[1]), sys.argv[2:]
    times = {(b, r): [] for b in bins for r in ROWS}
    cpu = {(b, r): [] for b in bins for r in ROWS}
    rng = random.Random(1)
    print(f"load average before: {os.getloadavg()}")
    for _ in range(runs):
        jobs = [(b, r) for b in bins for r in ROWS]
        rng.shuffle(jobs)
        for b, r in jobs:
            start = time.perf_counter()
            child = subprocess.Popen([b, "locate", PART, "--demold", "+y", *ROWS[r]],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            _, status, usage = os.wait4(child.pid, 0)
            times[(b, r)].append((time.perf_counter() - start) * 1e3)
            if os.waitstatus_to_exitcode(status) != 0:
                sys.exit(f"{b} {r} failed")
            cpu[(b, r)].append((usage.ru_utime + usage.ru_stime) * 1e3)
    print(f"load average after: {os.getloadavg()}")
    for b in bins:
        plain = times[(b, "plain")]
        for r in ROWS:
            t = times[(b, r)]
            ratio = statistics.median(x / p for x, p in zip(t, plain))
            print(f"{b}  {r:22s} median {statistics.median(t):7.1f} ms  "
                  f"x plain {ratio:5.2f}  (n={runs})")
    for b in bins:
        plain = cpu[(b, "plain")]
        for r in ROWS:
            t = cpu[(b, r)]
            ratio = statistics.median(x / p for x, p in zip(t, plain))
            print(f"{b}  {r:22s} CPU median {statistics.median(t):7.1f} ms  "
                  f"x plain's CPU {ratio:5.2f}  (n={runs})")


if __name__ == "__main__":
    main()
