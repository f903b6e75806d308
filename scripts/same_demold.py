#!/usr/bin/env python3
"""Checks `--demold auto` of a binary against one that draws every line ray by ray.

    python3 scripts/same_demold.py BASE_BINARY NEW_BINARY [PARTS_DIR]

On every built-in sample and shared part: the same chosen line, the same directions,
extents and gate checks; every line NEW drew (`evaluated`) with BASE's undercut area and
share to the bit; every line NEW left at its lower bound with a bound at most BASE's area
and above BASE's least area plus the tie (so it could not have been chosen). Prints one
line per part and the count that differ; exits 1 when any does. Standard library only.
"""
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
base, new = sys.argv[1], sys.argv[2]
parts = sys.argv[3] if len(sys.argv) > 3 else next(
    (p for p in (os.path.join(ROOT, *[".."] * up, "shared", "data", "parts") for up in (1, 2))
     if os.path.isdir(p)), os.path.join(ROOT, "..", "shared", "data", "parts"))
samples = subprocess.run([base, "sample", "--list"], capture_output=True, text=True).stdout
jobs = [("sample " + line.split()[0], ["--sample", line.split()[0]])
        for line in samples.splitlines() if line.strip()]
for f in sorted(os.listdir(parts)) if os.path.isdir(parts) else []:
    if f.lower().endswith(".stl"):
        units = "m" if "meters" in f else "in" if "inches" in f else "mm"
        jobs.append((f, [os.path.join(parts, f), "--units", units]))
bad = 0
for name, args in jobs:
    out = []
    for b in (base, new):
        cmd = [b, "locate", *args, "--demold", "auto", "--json"]
        r = subprocess.run(cmd, capture_output=True, text=True)
        out.append(json.loads(r.stdout)["demold_auto"])
    a, b = out
    tie = a["tie_mm2"]
    least = min(c["area_mm2"] for c in a["tried"])
    ok = a["chosen"] == b["chosen"] and a["tried"][a["chosen"]]["direction"] == b["tried"][b["chosen"]]["direction"]
    left = 0
    for ca, cb in zip(a["tried"], b["tried"]):
        ok &= ca["direction"] == cb["direction"] and ca["extent_mm"] == cb["extent_mm"] and ca["gate_qualifies"] == cb["gate_qualifies"]
        if cb["evaluated"]:
            ok &= ca["area_mm2"] == cb["area_mm2"] and ca["share"] == cb["share"]
        else:
            left += 1
            ok &= cb["area_mm2"] <= ca["area_mm2"] and cb["area_mm2"] > least + tie
    bad += not ok
    print(f"{'ok ' if ok else 'BAD'} {name}: chosen {b['chosen']}, {left} of {len(b['tried'])} lines left at a bound")
print("different:", bad)
sys.exit(1 if bad else 0)
