#!/usr/bin/env python3
"""What fresh memory costs on this machine: one process per run maps a block, touches each
4 KiB page once, and reports the time, on 2 MiB pages (advised for transparent huge pages,
as moldgate's allocator advises its large blocks) and on 4 KiB pages.

The time includes Python's loop over the pages (about 1 ms for 64 MiB). A page the kernel
hands out fresh is zeroed first; on a virtual machine whose host took the
memory back, the host must also provide it again, and that shows as runs far slower than the
rest. The spread of these runs is a floor under the spread of any command that maps fresh
memory, moldgate's included.

    python3 scripts/fresh_memory.py [--mib 64] [--runs 16]

Linux only; standard library only.
"""

import argparse
import mmap
import os
import statistics
import subprocess
import sys

CHILD = r"""
import mmap, sys, time
mib, huge = int(sys.argv[1]), sys.argv[2] == "huge"
size = mib << 20
start = time.perf_counter()
m = mmap.mmap(-1, size, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
m.madvise(mmap.MADV_HUGEPAGE if huge else mmap.MADV_NOHUGEPAGE)
view = memoryview(m)
for at in range(0, size, 4096):
    view[at] = 1
print(time.perf_counter() - start)
"""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mib", type=int, default=64, help="block size, MiB (default 64)")
    ap.add_argument("--runs", type=int, default=16, help="runs of each kind (default 16)")
    args = ap.parse_args()
    if not sys.platform.startswith("linux") or not hasattr(mmap, "MADV_HUGEPAGE"):
        sys.exit("fresh_memory.py needs Linux and Python 3.8 or later")
    if not 1 <= args.mib <= 4096 or not 1 <= args.runs <= 1000:
        sys.exit("--mib must be 1 to 4096 and --runs 1 to 1000")
    thp = "/sys/kernel/mm/transparent_hugepage/enabled"
    if os.path.exists(thp):
        print(f"transparent huge pages: {open(thp).read().strip()}")
    print(f"{args.mib} MiB touched page by page, one process per run, {args.runs} runs each; ms")
    for kind in ("huge", "small"):
        ms = []
        for _ in range(args.runs):
            out = subprocess.run([sys.executable, "-c", CHILD, str(args.mib), kind],
                                 check=True, capture_output=True, text=True).stdout
            ms.append(float(out) * 1e3)
        name = "2 MiB pages" if kind == "huge" else "4 KiB pages"
        print(f"{name}: median {statistics.median(ms):.1f}, min {min(ms):.1f}, "
              f"max {max(ms):.1f}; runs: {' '.join(f'{x:.1f}' for x in ms)}")


if __name__ == "__main__":
    main()
