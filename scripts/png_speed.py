#!/usr/bin/env python3
"""What `--png` costs against plain `locate`, for two binaries in one interleaved run.

Each round runs four commands once, in a random order: plain locate and locate --png, of
the base binary and of the new one (the speed table's two rows, for both). Prints per
binary the median whole-command time of each row and the median of the per-round ratio
--png / plain, then the median per-round ratio of the new --png to the base --png, and
the load average before and after.

    python3 scripts/png_speed.py BASE_BINARY NEW_BINARY [--runs 7] [--part PART.stl]
        [--demold +y]

Standard library only.
"""

import argparse
import os
import random
import statistics
import subprocess
import tempfile
import time

from same_json import PARTS


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base")
    ap.add_argument("new")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--part", default=os.path.join(PARTS, "esp32s3box_bottom_housing_352k.stl"))
    ap.add_argument("--demold", default="+y")
    args = ap.parse_args()
    out = tempfile.mkdtemp(prefix="png_speed")
    commands = {}
    for tag, binary in (("base", args.base), ("new", args.new)):
        plain = [binary, "locate", args.part, "--demold", args.demold]
        commands[(tag, "plain")] = plain
        commands[(tag, "png")] = [*plain, "--png", os.path.join(out, f"{tag}.png")]
    times = {k: [] for k in commands}
    print("load average before:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    rng = random.Random(1)
    for _ in range(args.runs):
        keys = list(commands)
        rng.shuffle(keys)
        for k in keys:
            t = time.perf_counter()
            subprocess.run(commands[k], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           check=True)
            times[k].append(time.perf_counter() - t)
    print("load average after: ", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    print(f"part {os.path.basename(args.part)}, demold {args.demold}, {args.runs} rounds")
    print("| binary | plain locate, median ms | --png, median ms | --png / plain (median of rounds) |")
    print("|---|---:|---:|---:|")
    for tag in ("base", "new"):
        plain, png = times[(tag, "plain")], times[(tag, "png")]
        ratio = statistics.median(p / q for p, q in zip(png, plain))
        print(f"| {tag} | {statistics.median(plain) * 1e3:.1f} | "
              f"{statistics.median(png) * 1e3:.1f} | {ratio:.2f} |")
    after = statistics.median(n / b for n, b in zip(times[("new", "png")], times[("base", "png")]))
    print(f"new --png / base --png: {after:.2f} (median of rounds)")


if __name__ == "__main__":
    main()
