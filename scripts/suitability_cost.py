#!/usr/bin/env python3
"""The gate-suitability map's cost against the balanced search, paired in one run.

    scripts/suitability_cost.py [PART.stl] [DEMOLD] [RUNS]

Default: the shared 352k part (esp32s3box_bottom_housing_352k.stl, demold +y) from
$MOLDGATE_PARTS (or /work/shared/data/parts), 7 runs. Each run is one
`moldgate locate --suitability --json` process: its report gives both the balanced search's
time (`fill.times.balanced_s`, which includes the balanced gate's own fill) and the map's
(`fill.times.suitability_s`), measured in the same process one after the other, so their
ratio is paired. Runs of the whole command with and without `--suitability` are interleaved
too. The load average is printed before and after, as the machine may be shared.
"""

import json
import os
import statistics
import subprocess
import sys
import time

repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
target = os.environ.get("CARGO_TARGET_DIR", os.path.join(repo, "target"))
cli = os.environ.get("MOLDGATE_CLI", os.path.join(target, "release", "moldgate"))
parts = os.environ.get("MOLDGATE_PARTS", "/work/shared/data/parts")
part = sys.argv[1] if len(sys.argv) > 1 else os.path.join(parts, "esp32s3box_bottom_housing_352k.stl")
demold = sys.argv[2] if len(sys.argv) > 2 else "+y"
runs = int(sys.argv[3]) if len(sys.argv) > 3 else 7

if not os.path.exists(cli):
    sys.exit(f"{cli} not built: cargo build --release -p moldgate-cli")
if not os.path.exists(part):
    sys.exit(f"{part} not found (set MOLDGATE_PARTS)")


def load():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def run(extra):
    t = time.perf_counter()
    out = subprocess.run(
        [cli, "locate", part, "--demold", demold, "--strategy", "balanced", "--json", *extra],
        capture_output=True, text=True, check=True,
    ).stdout
    return time.perf_counter() - t, json.loads(out)


print(f"part {os.path.basename(part)}, demold {demold}, {runs} runs; load average {load()}")
ratios, whole = [], []
for i in range(runs):
    with_s, r = run(["--suitability"])
    without_s, _ = run([])
    t = r["fill"]["times"]
    m = r["fill"]["suitability"]
    ratio = t["suitability_s"] / t["balanced_s"]
    ratios.append(ratio)
    whole.append(with_s / without_s)
    print(
        f"run {i + 1}: balanced {1e3 * t['balanced_s']:.0f} ms ({r['fill']['balanced']['search']['runs']} marches), "
        f"map {1e3 * t['suitability_s']:.0f} ms ({m['runs']} marches, {len(m['nodes'])} nodes, {m['exact']} exact), "
        f"map / balanced {ratio:.2f}; whole command {with_s:.2f} s with, {without_s:.2f} s without"
    )
print(
    f"median map / balanced {statistics.median(ratios):.2f} (min {min(ratios):.2f}, max {max(ratios):.2f}); "
    f"median whole command with / without {statistics.median(whole):.2f}; load average {load()}"
)
