#!/usr/bin/env python3
"""Whether two moldgate binaries draw the same pictures of every sample and shared part.

Runs `A locate ... --png` and `B locate ... --png` on every built-in sample and every
shared part (natural demolding direction from SOURCES.md, PP, default options otherwise)
with the option sets asked for (default: plain and --fill; also --fill coloured by flow length, two gates, the suitability map, and the wall of every facet), keeps both pictures in OUT
(`NAME.SET.base.png`, `NAME.SET.new.png`), and compares their pixels: per picture the
number of pixels that differ at all, the largest difference of one channel (0-255), and
the number of pixels whose difference is above --tolerance. Exits 1 when any picture has
pixels above the tolerance (or a different size, or one binary fails where the other does
not).

    python3 scripts/png_pictures.py BASE_BINARY NEW_BINARY OUT [--sets default,fill]
        [--tolerance 0] [--jobs 2] [--parts DIR] [--only NAME,...]

Standard library only (the pixels are decoded by scripts/png_same_pixels.py, slowly: a
few seconds a picture).
"""

import argparse
import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from png_same_pixels import pixels  # noqa: E402
from same_json import PARTS, NATURAL  # noqa: E402

SETS = {
    "default": [],
    "fill": ["--fill"],
    "fill-length": ["--fill", "--color-by", "flow-length"],
    "gates2": ["--fill", "--gates", "2"],
    "suitability": ["--suitability"],
    # The wall of every facet, pictured through the fill coloured by it.
    "walls": ["--wall-thickness", "--fill", "--color-by", "wall"],
}


def cases(base, parts, sets, only):
    samples = subprocess.run([base, "sample", "--list"], capture_output=True, text=True)
    names = [line.split()[0] for line in samples.stdout.splitlines() if line.strip()]
    for name in names:
        for s in sets:
            yield name, s, ["--sample", name, *SETS[s]]
    if not os.path.isdir(parts):
        print(f"no shared parts at {parts}: samples only", file=sys.stderr)
        return
    for file in sorted(os.listdir(parts)):
        stem, ext = os.path.splitext(file)
        if ext.lower() != ".stl" or stem not in NATURAL:
            continue
        units = "m" if "meters" in stem else "in" if "inches" in stem else "mm"
        for s in sets:
            args = [os.path.join(parts, file), "--units", units, "--demold", NATURAL[stem]]
            yield stem, s, [*args, *SETS[s]]


def compare(job):
    base, new, out, name, s, args, tolerance = job
    files = []
    codes = []
    for binary, tag in ((base, "base"), (new, "new")):
        path = os.path.join(out, f"{name}.{s}.{tag}.png")
        r = subprocess.run([binary, "locate", *args, "--png", path], capture_output=True)
        codes.append(r.returncode)
        files.append(path)
    label = f"{name} [{s}]"
    if codes[0] != codes[1]:
        return label, f"exit codes {codes[0]} and {codes[1]}", True
    if codes[0] != 0:
        return label, f"both exit {codes[0]}", False
    a, b = pixels(files[0]), pixels(files[1])
    if a[:3] != b[:3]:
        return label, f"sizes {a[:3]} and {b[:3]}", True
    width, bpp = a[0], a[2]
    differ = above = largest = 0
    for ra, rb in zip(a[3], b[3]):
        if ra == rb:
            continue
        for x in range(width):
            pa, pb = ra[x * bpp : x * bpp + 3], rb[x * bpp : x * bpp + 3]
            if pa != pb:
                d = max(abs(p - q) for p, q in zip(pa, pb))
                differ += 1
                largest = max(largest, d)
                above += d > tolerance
    sizes = os.path.getsize(files[0]), os.path.getsize(files[1])
    text = (f"{differ} of {a[0] * a[1]} pixels differ, largest channel difference {largest}, "
            f"{above} above {tolerance}; {sizes[0]} and {sizes[1]} bytes")
    return label, text, above > 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base")
    ap.add_argument("new")
    ap.add_argument("out")
    ap.add_argument("--parts", default=PARTS)
    ap.add_argument("--sets", default="default,fill")
    ap.add_argument("--tolerance", type=int, default=0,
                    help="largest accepted difference of a channel, 0-255 (default 0: exact)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="", help="part or sample names, comma-separated")
    args = ap.parse_args()
    sets = args.sets.split(",")
    for s in sets:
        if s not in SETS:
            sys.exit(f"unknown set {s!r}; known: {', '.join(SETS)}")
    only = {n for n in args.only.split(",") if n}
    os.makedirs(args.out, exist_ok=True)
    jobs = [(args.base, args.new, args.out, name, s, a, args.tolerance)
            for name, s, a in cases(args.base, args.parts, sets, only)
            if not only or name in only]
    bad = 0
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for label, text, failed in pool.map(compare, jobs):
            bad += failed
            print(f"{'DIFFERENT ' if failed else ''}{label}: {text}", flush=True)
    print(f"{len(jobs)} pictures compared, {bad} beyond the tolerance")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
