#!/usr/bin/env python3
"""Two moldgate binaries and the parse floor, paired: wall and CPU time of plain locate.

Each round runs `BASE locate PART --demold D`, `NEW locate PART --demold D` and (when
given) `FLOOR PART` (crates/moldgate/examples/parse_floor.rs) once each, in a random order,
so a slow or fast phase of the machine falls on all of them alike. Prints the median wall
and CPU time (user + system, from wait4) and the peak resident memory of each, the median
of the per-round ratios NEW / BASE (wall and CPU), and, with the floor, the median of the
per-round ratios of each binary to the floor: the last line of scripts/speed_table.py,
before and after, from the same rounds. The load average is printed before and after.

    python3 scripts/paired_floor.py ROUNDS PART DEMOLD BASE_BINARY NEW_BINARY [FLOOR] [-- ARGS]

ARGS, after `--`, are passed to both binaries' locate (e.g. `--parting-line longest`).

Standard library only.
"""
import os
import random
import statistics
import subprocess
import sys
import time

argv, extra = sys.argv, []
if "--" in argv:
    argv, extra = argv[:argv.index("--")], argv[argv.index("--") + 1:]
if len(argv) < 6:
    sys.exit(__doc__)
rounds, part, demold, a, b = int(argv[1]), argv[2], argv[3], argv[4], argv[5]
floor = argv[6] if len(argv) > 6 else None
cmds = {"base": [a, "locate", part, "--demold", demold, *extra],
        "new": [b, "locate", part, "--demold", demold, *extra]}
if floor:
    cmds["floor"] = [floor, part]
res = {k: [] for k in cmds}
print("load average before:", " ".join(f"{x:.2f}" for x in os.getloadavg()))
for _ in range(rounds):
    order = list(cmds)
    random.shuffle(order)
    for k in order:
        start = time.perf_counter()
        proc = subprocess.Popen(cmds[k], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - start
        if status != 0:
            sys.exit(f"{' '.join(cmds[k])}: exit status {status}")
        res[k].append((wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss))
print("load average after: ", " ".join(f"{x:.2f}" for x in os.getloadavg()))
for k, v in res.items():
    print(f"{k:6s} wall median {statistics.median(x[0] for x in v) * 1e3:7.1f} ms"
          f"  cpu median {statistics.median(x[1] for x in v) * 1e3:7.1f} ms"
          f"  peak RSS {max(x[2] for x in v) / 1024:.1f} MiB")
wall = [n[0] / o[0] for n, o in zip(res["new"], res["base"])]
cpu = [n[1] / o[1] for n, o in zip(res["new"], res["base"])]
print(f"new / base, median of rounds: wall {statistics.median(wall):.3f}"
      f"  cpu {statistics.median(cpu):.3f}  ({rounds} rounds)")
if floor:
    for k in ("base", "new"):
        ratio = [x[0] / f[0] for x, f in zip(res[k], res["floor"])]
        print(f"{k} plain locate / parse floor: {statistics.median(ratio):.2f} (median of rounds)")
