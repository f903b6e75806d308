#!/usr/bin/env python3
"""Whole-command speed of moldgate against the Python reference, in the same run.

Times `moldgate locate PART --demold D` from process start to exit (median of N runs), then
the reference (`../shared/reference/gate_ref.py`, Embree engine, no flow evaluation) on the
same part and direction, and prints both, their ratio, and moldgate's peak resident memory.

    cargo build --release -p moldgate-cli
    pip install trimesh numpy scipy embreex rtree      # for the reference only
    python3 scripts/speed.py [PART] [--demold +y] [--runs 21] [--reference-runs 5]

Standard library only. The reference is skipped, with a message, when it or its
dependencies are missing.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared")
DEFAULT_PART = os.path.join(SHARED, "data", "parts", "esp32s3box_bottom_housing_352k.stl")
AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1)}


def direction_vector(text):
    sign = -1 if text.startswith("-") else 1
    axis = text.lstrip("+-")
    return [sign * c for c in AXES[axis]]


def time_runs(cmd, runs):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - start)
    return times


def peak_rss_kib(cmd):
    """Peak resident set of one run, from the kernel's accounting of the child."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(before, after)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", nargs="?", default=DEFAULT_PART)
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--runs", type=int, default=21)
    ap.add_argument("--reference-runs", type=int, default=5)
    args = ap.parse_args()

    binary = os.path.join(ROOT, "target", "release", "moldgate")
    if not os.path.exists(binary):
        sys.exit("build first: cargo build --release -p moldgate-cli")
    if not os.path.exists(args.part):
        sys.exit(f"part not found: {args.part}")

    ours = [binary, "locate", args.part, "--demold", args.demold]
    time_runs(ours, 2)  # warm the page cache
    t = time_runs(ours, args.runs)
    median = statistics.median(t)
    rss = peak_rss_kib(ours)
    print(f"part: {os.path.basename(args.part)}, demold {args.demold}, {os.cpu_count()} cores")
    print(
        f"moldgate:  median {median * 1e3:.1f} ms, min {min(t) * 1e3:.1f} ms, "
        f"max {max(t) * 1e3:.1f} ms over {args.runs} runs; peak RSS {rss / 1024:.1f} MiB"
    )

    ref = os.path.join(SHARED, "reference", "gate_ref.py")
    theirs = [sys.executable, ref, args.part, "--engine", "trimesh", "--no-flow", "--dir"]
    theirs += [str(c) for c in direction_vector(args.demold)]
    theirs += ["--out", os.devnull]
    probe = subprocess.run(
        [sys.executable, "-c", "import trimesh, embreex, scipy"], capture_output=True
    )
    if not os.path.exists(ref) or probe.returncode != 0:
        print("reference: skipped (needs ../shared/reference and trimesh, embreex, scipy)")
        return
    r = time_runs(theirs, args.reference_runs)
    ref_median = statistics.median(r)
    print(
        f"reference: median {ref_median * 1e3:.0f} ms over {args.reference_runs} runs "
        f"(Python, trimesh + Embree, whole command)"
    )
    print(f"ratio: moldgate is {ref_median / median:.1f} times faster")


if __name__ == "__main__":
    main()
