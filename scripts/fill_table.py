#!/usr/bin/env python3
"""The table in docs/fill-analysis.md of the paper gate against the balanced gate on the shared parts.

Runs `moldgate locate PART --demold D --units U --fill --json` on every shared part (natural
demolding direction from ../shared/data/parts/SOURCES.md or $MOLDGATE_PARTS, PP, default options otherwise)
and prints a Markdown table: bodies, flow length L_max, L/t, Eq. 1 pressure and estimated
fill time for both gates, the improvement, the field runs of the balanced search and the
fill-analysis time (ray tree, wall thickness, voxels, paper-gate fields and balanced search,
from the report's own timings; best of --runs). Every row has the header's column count
(checked); the binary is $CARGO_TARGET_DIR/release/moldgate unless --binary is given.

    cargo build --release -p moldgate-cli
    python3 scripts/fill_table.py [--runs 3] [--objective length|resistance]

Standard library only. Exits non-zero if a balanced gate's L_max exceeds the paper gate's.
"""

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from speed import NATURAL  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PARTS = os.environ.get("MOLDGATE_PARTS", os.path.join(ROOT, "..", "shared", "data", "parts"))


def units(stem):
    if "meters" in stem:
        return "m"
    if "inches" in stem:
        return "in"
    return "mm"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--objective", default="length")
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    ap.add_argument("--binary", default=os.path.join(target, "release", "moldgate"))
    args = ap.parse_args()
    if not os.path.isdir(PARTS):
        sys.exit(f"no shared parts at {PARTS}")
    header = ["part", "triangles", "bodies", "cells", "paper L_max mm", "L/t", "ΔP MPa",
              "fill s", "balanced L_max mm", "L/t", "ΔP MPa", "fill s", "better by", "runs",
              "fill ms"]

    def row(cells):
        if len(cells) != len(header):
            sys.exit(f"a row of {len(cells)} columns for {len(header)}: {cells}")
        print("| " + " | ".join(str(c) for c in cells) + " |")

    print("| " + " | ".join(header) + " |")
    print("|---|" + "---:|" * (len(header) - 1))
    worse = []
    for name in sorted(os.listdir(PARTS)):
        stem, ext = os.path.splitext(name)
        if ext.lower() != ".stl" or stem not in NATURAL:
            continue
        cmd = [args.binary, "locate", os.path.join(PARTS, name), "--demold", NATURAL[stem],
               "--units", units(stem), "--fill", "--objective", args.objective, "--json"]
        best = None
        report = None
        for _ in range(args.runs):
            out = subprocess.run(cmd, capture_output=True, text=True)
            if out.returncode != 0:
                report = None
                reason = f"no gate (exit {out.returncode})"
                break
            report = json.loads(out.stdout)
            t = report["fill"]["times"]
            s = t["tree_s"] + t["wall_s"] + t["voxels_s"] + t["paper_s"] + t["balanced_s"]
            best = s if best is None else min(best, s)
        if report is None:
            row([stem, reason] + [""] * (len(header) - 2))
            continue
        f = report["fill"]
        p, b = f["paper"], f["balanced"]
        bf = b["fill"]
        if bf["l_max_mm"] > p["l_max_mm"] + 1e-9:
            worse.append(stem)
        row([stem, report["mesh"]["triangles"], f["bodies"], f["cells"],
             f"{p['l_max_mm']:.1f}", f"{p['flow_ratio']:.0f}", f"{p['pressure_mpa']:.1f}",
             f"{p['fill_time_s']:.3f}", f"{bf['l_max_mm']:.1f}", f"{bf['flow_ratio']:.0f}",
             f"{bf['pressure_mpa']:.1f}", f"{bf['fill_time_s']:.3f}",
             f"{b['improvement_pct']:.1f} %", b["search"]["runs"], f"{best * 1e3:.0f}"])
    if worse:
        sys.exit(f"balanced gate worse than the paper gate on: {', '.join(worse)}")


if __name__ == "__main__":
    main()
