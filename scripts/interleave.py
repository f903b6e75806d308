#!/usr/bin/env python3
"""Whole-command timing of several moldgate binaries, run in turn, so that they share the
machine's slow and fast phases: median, min and max per binary.

    python3 scripts/interleave.py RUNS OLD_BINARY NEW_BINARY [...]

Times `BINARY locate <shared 352k part> --demold +y`. Standard library only.
"""
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
part = os.path.join(
    ROOT, "..", "shared", "data", "parts", "esp32s3box_bottom_housing_352k.stl"
)
if len(sys.argv) < 3 or not os.path.exists(part):
    sys.exit("usage: interleave.py RUNS BINARY [BINARY ...] (needs ../shared/data/parts)")
runs = int(sys.argv[1])
bins = sys.argv[2:]
t = {b: [] for b in bins}
for _ in range(runs):
    for b in bins:
        s = time.perf_counter()
        subprocess.run([b, "locate", part, "--demold", "+y"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        t[b].append((time.perf_counter() - s) * 1e3)
for b in bins:
    print(f"{b}: median {statistics.median(t[b]):.1f} ms  min {min(t[b]):.1f}  max {max(t[b]):.1f}  (n={runs})")
