#!/usr/bin/env python3
"""What each option costs on every shared part: the speed table's rows, part by part.

The speed table (scripts/speed_table.py) measures one large part. This script runs the same
commands on each part listed in the shared parts' SOURCES.md, with the part's units and its
natural demolding direction from that file, and prints per part the median whole-command
time of plain `moldgate locate` and, for every option, its time and the median of its
per-round ratio to plain locate: fill (--fill), balanced (--strategy balanced), gates3
(--gates 3), walls (--wall-thickness), auto (--demold auto), png (--png). Each round runs
every command of a part once, in a random order. The load average is printed before and
after.

    cargo build --release -p moldgate-cli
    python3 scripts/speed_parts.py [--runs 5] [--binary target/release/moldgate]
        [--parts DIR] [--only fill,balanced,...]

A part the command refuses (exit status other than 0) shows its status in its cells: its
times are those of the refusal.

Standard library only.
"""

import argparse
import os
import random
import re
import statistics
import subprocess
import tempfile
import time

# The speed table's folders and load average (this script's sibling).
from speed_table import SHARED, TARGET, loadavg

# (name, options); None: `--demold auto` in place of the part's direction.
OPTIONS = [
    ("fill", ["--fill"]),
    ("balanced", ["--strategy", "balanced"]),
    ("gates3", ["--gates", "3"]),
    ("walls", ["--wall-thickness"]),
    ("auto", None),
    ("png", ["--png", "PNG"]),
]


def parts_of(folder):
    """(file, units, direction) of each part in SOURCES.md's table."""
    parts = []
    with open(os.path.join(folder, "SOURCES.md"), encoding="utf-8") as f:
        for line in f:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) < 11 or not os.path.isfile(os.path.join(folder, cells[0])):
                continue
            units = "m" if "METRES" in cells[8] else "in" if "INCHES" in cells[8] else "mm"
            axis = re.match(r"([+-]?)([XYZ])", cells[10])
            if axis is None:
                raise SystemExit(f"SOURCES.md: no direction in the row of {cells[0]}")
            parts.append((cells[0], units, (axis.group(1) or "+") + axis.group(2).lower()))
    return parts


def run(cmd):
    start = time.perf_counter()
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start, done.returncode


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5, help="rounds a part (default 5)")
    ap.add_argument("--binary", default=os.path.join(TARGET, "release", "moldgate"))
    ap.add_argument("--parts", default=os.path.join(SHARED, "data", "parts"))
    ap.add_argument("--only", help="comma-separated names to run besides plain locate "
                    "(fill, balanced, gates3, walls, auto, png)")
    a = ap.parse_args()
    if a.runs < 1:
        raise SystemExit("--runs must be at least 1")
    for path, what in ((a.binary, "the moldgate binary (cargo build --release -p moldgate-cli)"),
                       (os.path.join(a.parts, "SOURCES.md"), "the shared parts' SOURCES.md")):
        if not os.path.isfile(path):
            raise SystemExit(f"{path}: not found ({what})")
    options = OPTIONS
    if a.only:
        names = [n.strip() for n in a.only.split(",")]
        unknown = [n for n in names if n not in dict(OPTIONS)]
        if unknown:
            raise SystemExit(f"--only: unknown {unknown}; the names are {[n for n, _ in OPTIONS]}")
        options = [o for o in OPTIONS if o[0] in names]

    with tempfile.TemporaryDirectory(prefix="moldgate-speed-") as folder:
        table(a, options, os.path.join(folder, "part.png"))


def table(a, options, png):
    """Runs the rounds of every part and prints the table; `png` is where --png writes."""
    print(f"binary {a.binary}; {a.runs} rounds a part, {os.cpu_count()} cores")
    print(f"load average before: {loadavg()}")
    print()
    print("| part | plain locate, ms | " + " | ".join(f"{n}: ms (ratio)" for n, _ in options) + " |")
    print("|---|---:|" + "---:|" * len(options))
    for file, units, direction in parts_of(a.parts):
        base = [a.binary, "locate", os.path.join(a.parts, file), "--units", units, "--quiet"]
        commands = {"plain": base + ["--demold", direction]}
        for name, extra in options:
            if extra is None:
                commands[name] = base + ["--demold", "auto"]
            else:
                commands[name] = base + ["--demold", direction] + [png if x == "PNG" else x for x in extra]
        times = {name: [] for name in commands}
        status = {name: 0 for name in commands}
        for _ in range(a.runs):
            order = list(commands)
            random.shuffle(order)
            for name in order:
                t, rc = run(commands[name])
                times[name].append(t)
                status[name] = status[name] or rc
        plain = times["plain"]

        def cell(name):
            ms = 1e3 * statistics.median(times[name])
            text = f"{ms:.0f}"
            if name != "plain":
                ratio = statistics.median(t / p for t, p in zip(times[name], plain))
                text += f" ({ratio:.1f})"
            return text + (f" exit {status[name]}" if status[name] else "")

        print(f"| {file} | " + " | ".join(cell(n) for n in commands) + " |", flush=True)
    print()
    print(f"load average after:  {loadavg()}")


if __name__ == "__main__":
    main()
