#!/usr/bin/env python3
"""Whole-command timing of several moldgate binaries, run in turn, so that they share the
machine's slow and fast phases: median, min and max per binary, and against the first
binary the median of the per-round differences and ratios (paired: each round runs every
binary once, in a random order, so a change of phase between rounds cancels out).

    python3 scripts/interleave.py RUNS OLD_BINARY NEW_BINARY [...]

Times `BINARY locate <shared 352k part> --demold +y`. Standard library only.
"""
import os
import random
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The shared parts beside the repository (or beside the folder of work trees).
part = next((p for p in (os.path.join(ROOT, *[".."] * up, "shared", "data", "parts",
                                      "esp32s3box_bottom_housing_352k.stl") for up in (1, 2))
             if os.path.exists(p)), "")
if len(sys.argv) < 3 or not os.path.exists(part):
    sys.exit("usage: interleave.py RUNS BINARY [BINARY ...] (needs ../shared/data/parts)")
runs = int(sys.argv[1])
bins = sys.argv[2:]
t = {b: [] for b in bins}
rng = random.Random(1)
for _ in range(runs):
    order = list(bins)
    rng.shuffle(order)
    for b in order:
        s = time.perf_counter()
        subprocess.run([b, "locate", part, "--demold", "+y"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t[b].append((time.perf_counter() - s) * 1e3)
first = bins[0]
for b in bins:
    diff = statistics.median(x - y for x, y in zip(t[b], t[first]))
    ratio = statistics.median(x / y for x, y in zip(t[b], t[first]))
    print(
        f"{b}: median {statistics.median(t[b]):.1f} ms  min {min(t[b]):.1f}  max {max(t[b]):.1f}"
        f"  paired against the first: {diff:+.1f} ms, ratio {ratio:.3f}  (n={runs})"
    )
