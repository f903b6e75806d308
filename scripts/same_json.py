#!/usr/bin/env python3
"""Checks that two moldgate binaries give the same JSON report on every sample and shared part.

For refactors that must not change behaviour: runs `A locate ... --json` and
`B locate ... --json` on every built-in sample and every shared part (natural demolding
direction from SOURCES.md, PP, default options otherwise) with several option sets, and
compares the exit codes and the reports, less their time keys (`timings`, `times`,
`time_s`), which vary from run to run. Prints one line per difference (its first differing
path) and a count. `--ignore` leaves more keys out (such as `runs`, the marches a search took, after a change
that makes the same answer with fewer). `--rel-tol` accepts floating-point noise (the undercut areas of
`--demold auto` are summed in parallel in an order that varies from run to run, so even one
binary differs from itself in their last bits). `--glb` also writes each run's GLB and
compares the two files byte for byte (for changes to the 3D scene's writer).

    python3 scripts/same_json.py BASE_BINARY NEW_BINARY [--parts DIR] [--sets NAME,...]
        [--jobs N] [--skip-large] [--ignore KEY,...] [--glb]

Standard library only. Exits 1 when any report differs, 0 when all are the same.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from speed import NATURAL  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The shared parts beside the repository (or beside the folder of work trees).
PARTS = next((p for p in (os.path.join(ROOT, *[".."] * up, "shared", "data", "parts")
                          for up in (1, 2)) if os.path.isdir(p)),
             os.path.join(ROOT, "..", "shared", "data", "parts"))

# The option sets, by name.
SETS = {
    "default": [],
    "fill": ["--fill"],
    "gates2": ["--fill", "--gates", "2"],
    "gates3": ["--fill", "--gates", "3"],
    "balanced": ["--strategy", "balanced"],
    "resistance": ["--fill", "--objective", "resistance"],
    "wallfill": ["--wall-thickness", "--fill"],
    "autofill": ["--demold", "auto", "--fill"],
    "autowall": ["--demold", "auto", "--wall-thickness"],
    "autoaesthetic": ["--demold", "auto", "--aesthetic"],
    "aesthetic": ["--aesthetic"],
    "auto": ["--demold", "auto"],
    "wall": ["--wall-thickness"],
    "volume2d": ["--centre", "volume", "--nearest", "2d", "--thickness-rule", "ignore"],
}

TIME_KEYS = {"timings", "times", "time_s"}

# Parts whose fill runs take long; --skip-large leaves their fill sets out.
LARGE = {"esp32s3box_bottom_housing_352k", "framework_desktop_top_cover_121k"}


def strip(v):
    """The report less its time keys."""
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in TIME_KEYS}
    if isinstance(v, list):
        return [strip(x) for x in v]
    return v


def run(binary, args, glb=None):
    """The exit code, the report less its times, the messages, and the GLB's bytes when
    `glb` names a file to write it to (None when not asked for or not written)."""
    extra = ["--glb", glb] if glb else []
    out = subprocess.run([binary, "locate", *args, "--json", *extra], capture_output=True,
                         text=True)
    try:
        report = strip(json.loads(out.stdout)) if out.stdout.strip() else None
    except json.JSONDecodeError:
        report = ("not JSON", out.stdout[:200])
    scene = None
    if glb and os.path.exists(glb):
        with open(glb, "rb") as f:
            scene = f.read()
        os.remove(glb)
    return out.returncode, report, out.stderr.strip(), scene


def first_difference(a, b, path="$"):
    """Where two JSON values first differ, as a path and both values."""
    if type(a) is not type(b):
        return f"{path}: {a!r} != {b!r}"
    if isinstance(a, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{path}.{k}: only in {'new' if k in b else 'base'}"
            d = first_difference(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{path}: {len(a)} items != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if isinstance(a, float) and REL_TOL > 0 and abs(a - b) <= REL_TOL * max(abs(a), abs(b)):
        return None
    return None if a == b else f"{path}: {a!r} != {b!r}"


def cases(parts, sets, skip_large):
    samples = subprocess.run([BASE, "sample", "--list"], capture_output=True, text=True)
    for line in samples.stdout.splitlines():
        name = line.split()[0]
        for s in sets:
            yield f"sample {name} [{s}]", ["--sample", name, *SETS[s]]
    if not os.path.isdir(parts):
        print(f"no shared parts at {parts}: samples only", file=sys.stderr)
        return
    for name in sorted(os.listdir(parts)):
        stem, ext = os.path.splitext(name)
        if ext.lower() != ".stl" or stem not in NATURAL:
            continue
        units = "m" if "meters" in stem else "in" if "inches" in stem else "mm"
        for s in sets:
            extra = SETS[s]
            if skip_large and stem in LARGE and s not in ("default", "aesthetic"):
                continue
            demold = [] if "--demold" in extra else ["--demold", NATURAL[stem]]
            yield f"{stem} [{s}]", [os.path.join(parts, name), "--units", units, *demold, *extra]


def main():
    global BASE
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base")
    ap.add_argument("new")
    ap.add_argument("--parts", default=PARTS)
    ap.add_argument("--sets", default=",".join(SETS))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--skip-large", action="store_true")
    ap.add_argument("--ignore", default="",
                    help="more keys to leave out of the comparison, comma-separated")
    ap.add_argument("--rel-tol", type=float, default=0.0,
                    help="accept numbers this close (relative); 0, the default, is exact")
    ap.add_argument("--glb", action="store_true",
                    help="also compare the GLB files the two binaries write, byte for byte")
    args = ap.parse_args()
    BASE = args.base
    TIME_KEYS.update(k for k in args.ignore.split(",") if k)
    global REL_TOL
    REL_TOL = args.rel_tol
    sets = args.sets.split(",")
    for s in sets:
        if s not in SETS:
            sys.exit(f"unknown option set {s!r} (known: {', '.join(SETS)})")
    todo = list(cases(args.parts, sets, args.skip_large))

    scratch = tempfile.mkdtemp(prefix="same-json-")

    def compare(numbered):
        i, (label, a) = numbered
        glb = (lambda side: os.path.join(scratch, f"{i}-{side}.glb")) if args.glb else None
        ca, ra, ea, ga = run(args.base, a, glb and glb("base"))
        cb, rb, eb, gb = run(args.new, a, glb and glb("new"))
        if ca != cb:
            return f"{label}: exit code {ca} != {cb} ({ea[:120]!r} / {eb[:120]!r})"
        d = first_difference(ra, rb)
        if d:
            return f"{label}: {d}"
        if ga != gb:
            if ga is None or gb is None:
                return f"{label}: GLB written by {'new' if ga is None else 'base'} only"
            at = next((k for k, (x, y) in enumerate(zip(ga, gb)) if x != y),
                      min(len(ga), len(gb)))
            return f"{label}: GLB differs from byte {at} ({len(ga)} / {len(gb)} bytes)"
        return None

    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        results = list(pool.map(compare, enumerate(todo)))
    os.rmdir(scratch)
    differences = [r for r in results if r]
    for d in differences:
        print(d)
    print(f"{len(todo)} runs compared, {len(differences)} different")
    sys.exit(1 if differences else 0)


BASE = None
REL_TOL = 0.0

if __name__ == "__main__":
    main()
