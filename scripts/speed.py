#!/usr/bin/env python3
"""Whole-command speed of moldgate against the Python reference, in the same run.

Times `moldgate locate PART --demold D` from process start to exit (median of N runs), then
the reference (`../shared/reference/gate_ref.py`, Embree engine, no flow evaluation) on the
same part and direction, and prints both, their ratio, and moldgate's peak resident memory.

    cargo build --release -p moldgate-cli
    pip install trimesh numpy scipy embreex rtree      # for the reference only
    python3 scripts/speed.py [PART] [--demold +y] [--runs 21] [--reference-runs 5]
    python3 scripts/speed.py --all-parts      # every shared part, natural direction, moldgate only

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


def time_runs(cmd, runs, check=True):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(cmd, check=check, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - start)
    return times


def peak_rss_kib(cmd):
    """Peak resident set of one run, from the kernel's accounting of the child."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(before, after)


# Natural demolding directions of the shared parts (../shared/data/parts/SOURCES.md).
NATURAL = {
    "comma2_injection_molded_mount": "+x",
    "comma_ram_connector_cap": "-z",
    "deskhop_case_bottom": "+z",
    "esp32s3box_bottom_housing_352k": "+y",
    "esp32s3box_top_housing": "-y",
    "framework_desktop_blank_tile": "-z",
    "framework_desktop_top_cover_121k": "-x",
    "framework_expansion_card_shell": "+y",
    "prusa_heatbed_cable_cover_clip_ascii": "+z",
    "prusa_lcd_knob": "+z",
    "prusa_psu_cover_mk3_ascii": "+z",
    "prusa_raspberry_cover_ascii_open": "+z",
    "sc64_shell_back": "-z",
    "screwcap_oralb_75ml_ascii": "+z",
    "trimesh_ADIS16480_meters_ascii": "+y",
    "trimesh_featuretype_inches": "+z",
    "watchy_yatari_bottom": "-z",
    "watchy_yatari_top": "+z",
}


def all_parts(binary, runs):
    folder = os.path.dirname(DEFAULT_PART)
    print("| part | triangles | whole command, median ms | exit code |")
    print("|---|---:|---:|---:|")
    for name in sorted(os.listdir(folder)):
        stem, ext = os.path.splitext(name)
        if ext.lower() != ".stl" or stem not in NATURAL:
            continue
        units = "m" if "meters" in stem else "in" if "inches" in stem else "mm"
        cmd = [binary, "locate", os.path.join(folder, name), "--demold", NATURAL[stem]]
        cmd += ["--units", units]
        median = statistics.median(time_runs(cmd, runs, check=False))  # exit 4: no gate
        result = subprocess.run(cmd, capture_output=True, text=True)
        triangles = next(
            (line.split(",")[1].split()[0] for line in result.stdout.splitlines()
             if "triangles" in line),
            "?",
        )
        print(f"| {stem} | {triangles} | {median * 1e3:.1f} | {result.returncode} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", nargs="?", default=DEFAULT_PART)
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--runs", type=int, default=21)
    ap.add_argument("--reference-runs", type=int, default=5)
    ap.add_argument("--all-parts", action="store_true", help="time every shared part instead")
    args = ap.parse_args()

    binary = os.path.join(ROOT, "target", "release", "moldgate")
    if not os.path.exists(binary):
        sys.exit("build first: cargo build --release -p moldgate-cli")
    if args.all_parts:
        all_parts(binary, 7)
        return
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

    if args.reference_runs < 1:
        print("reference: skipped (--reference-runs 0)")
        return
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
