#!/usr/bin/env python3
"""What a second core gives moldgate on this machine: one command on one thread, alone and
two copies at once, and the same command on every core.

A command that keeps two cores busy can be at most twice as fast as on one; on a machine
whose two cores are two hardware threads of one physical core (common on cloud virtual
machines), or share its caches and memory bandwidth, it gains less, and the speed table's
ratios of two-core commands carry that limit. Each round runs, in a random order:

- `alone`: the command with RAYON_NUM_THREADS=1;
- `pair`: two copies of it with RAYON_NUM_THREADS=1, started together (the round's time
  is the later one's);
- `every core`: the command with its default threads.

It prints the medians of the wall times and two figures from them: the throughput of two
one-thread copies against one (2 x alone / pair: 2.0 when the second core is a whole
core, 1.0 when it adds nothing), and the speed-up of the command on every core (alone /
every core). The load average is printed before and after.

    cargo build --release -p moldgate-cli
    python3 scripts/core_pair.py [--runs 11] [--binary target/release/moldgate]
        [--part PART.stl] [-- COMMAND OPTIONS...]

The command is `locate PART --demold +y --quiet` followed by the options after `--`
(default `--fill`; a `--demold` among them takes the place of `+y`); the part defaults to
the shared 352k-triangle housing.

Linux only (os.wait4); standard library only.
"""

import argparse
import os
import random
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The shared parts beside the clone (as scripts/speed_table.py finds them).
SHARED = next((p for p in (os.path.join(ROOT, *[".."] * up, "shared") for up in (1, 2))
               if os.path.isdir(p)), os.path.join(ROOT, "..", "shared"))
DEFAULT_PART = os.path.join(SHARED, "data", "parts", "esp32s3box_bottom_housing_352k.stl")
TARGET = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))


def start(binary, args, threads):
    """Starts one run; `threads` None keeps the default."""
    env = dict(os.environ)
    env.pop("RAYON_NUM_THREADS", None)
    if threads is not None:
        env["RAYON_NUM_THREADS"] = str(threads)
    return subprocess.Popen([binary, *args], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=env)


def wait(child, what):
    _, status, _ = os.wait4(child.pid, 0)
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.exit(f"{what}: exit code {code} (run it alone to see its message)")


def timed(binary, args, copies, threads):
    """Wall seconds until every one of `copies` runs started together has ended."""
    begin = time.perf_counter()
    children = [start(binary, args, threads) for _ in range(copies)]
    for child in children:
        wait(child, f"{binary} {' '.join(args)}")
    return time.perf_counter() - begin


def main():
    argv = sys.argv[1:]
    extra = ["--fill"]
    if "--" in argv:
        split = argv.index("--")
        argv, extra = argv[:split], argv[split + 1:]
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=11, help="rounds (default 11)")
    ap.add_argument("--binary", default=os.path.join(TARGET, "release", "moldgate"))
    ap.add_argument("--part", default=DEFAULT_PART)
    args = ap.parse_args(argv)
    if not hasattr(os, "wait4"):
        sys.exit("core_pair.py needs Linux (os.wait4)")
    if not 1 <= args.runs <= 1000:
        sys.exit("--runs must be 1 to 1000")
    for path, what in ((args.binary, "binary"), (args.part, "part")):
        if not os.path.isfile(path):
            sys.exit(f"no {what} at {path}")
    demold = [] if "--demold" in extra else ["--demold", "+y"]
    command = ["locate", args.part, *demold, "--quiet", *extra]
    print("load average before:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    kinds = {"alone": (1, 1), "pair": (2, 1), "every core": (1, None)}
    times = {k: [] for k in kinds}
    rng = random.Random(1)
    for _ in range(args.runs):
        order = list(kinds)
        rng.shuffle(order)
        for kind in order:
            copies, threads = kinds[kind]
            times[kind].append(timed(args.binary, command, copies, threads))
    print("load average after: ", " ".join(f"{x:.2f}" for x in os.getloadavg()))
    median = {k: statistics.median(v) * 1e3 for k, v in times.items()}
    print(f"{args.runs} rounds of: moldgate {' '.join(command)} ({os.cpu_count()} cores)")
    print("| run | wall ms median |")
    print("|---|---:|")
    for kind in kinds:
        print(f"| {kind} | {median[kind]:.1f} |")
    print(f"two one-thread copies do {2 * median['alone'] / median['pair']:.2f} times the work "
          f"of one; the command on every core runs "
          f"{median['alone'] / median['every core']:.2f} times as fast as on one thread")


if __name__ == "__main__":
    main()
