#!/usr/bin/env python3
"""moldgate's wall thickness against Embree's rays on the same part, in the same run.

Each round runs, in a random order, `moldgate locate PART --demold D --wall-thickness --json`
(its report's `timings.wall_s`, the whole wall-thickness stage, and `timings.tree_s`, the ray
tree it builds first) and Embree's first-hit call on the same rays through trimesh
(`mesh.ray.intersects_first`, from every facet's centroid along its inverted normal, the
ray moldgate casts first per facet), and prints the medians and the paired ratios with the
load average. Embree's scene is built once, before the rounds, and timed apart.

    cargo build --release -p moldgate-cli
    python3 scripts/wall_rays_embree.py [PART] [--demold +y] [--runs 7] [--binary PATH]
        [--before PATH]

With --before, a second moldgate binary runs in the same shuffled rounds, and the paired
ratios of its stage and tree to the first binary's are printed too (after / before).

Needs a Python with trimesh and embreex (the reference implementation's, see its README):
without them, or without the part, it says so and exits 0 having measured nothing.
"""

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(ROOT, "..", "shared")
DEFAULT_PART = os.path.join(SHARED, "data", "parts", "esp32s3box_bottom_housing_352k.stl")


def skip(why):
    print(f"wall_rays_embree: skipped: {why}")
    sys.exit(0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("part", nargs="?", default=DEFAULT_PART)
    ap.add_argument("--demold", default="+y")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument(
        "--binary",
        default=os.path.join(
            os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "moldgate"
        ),
    )
    ap.add_argument("--before", help="a second moldgate binary, run in the same rounds")
    a = ap.parse_args()
    if a.before and not os.path.exists(a.before):
        skip(f"no moldgate binary at {a.before}")
    if not os.path.exists(a.part):
        skip(f"no part at {a.part}")
    if not os.path.exists(a.binary):
        skip(f"no moldgate binary at {a.binary} (cargo build --release -p moldgate-cli)")
    try:
        import numpy as np
        import trimesh
        import embreex  # noqa: F401  (trimesh uses it when it is installed)
    except ImportError as e:
        skip(f"needs trimesh and embreex ({e})")

    mesh = trimesh.load(a.part, process=True)
    if not isinstance(mesh, trimesh.Trimesh):
        skip("the part did not load as one mesh")
    diagonal = float(np.linalg.norm(mesh.extents))
    normals = mesh.face_normals
    # moldgate ignores hits nearer than 1e-6 of the diagonal and skips the start facet;
    # Embree gets the same rays started that far inside.
    origins = mesh.triangles_center - normals * (1e-6 * diagonal)
    directions = -normals
    t = time.perf_counter()
    mesh.ray.intersects_first(origins[:1], directions[:1])  # builds the scene
    scene_s = time.perf_counter() - t
    engine = type(mesh.ray).__module__
    if "embree" not in engine:
        skip(f"trimesh's rays are {engine}, not Embree")

    binaries = {"moldgate": a.binary}
    if a.before:
        binaries["before"] = a.before
    stage = {who: [] for who in binaries}
    trees = {who: [] for who in binaries}
    embree = []
    rng = random.Random(1)
    for _ in range(a.runs):
        order = list(binaries) + ["embree"]
        rng.shuffle(order)
        for who in order:
            if who in binaries:
                out = subprocess.run(
                    [binaries[who], "locate", a.part, "--demold", a.demold, "--wall-thickness",
                     "--json"],
                    check=True,
                    capture_output=True,
                    text=True,
                ).stdout
                timings = json.loads(out)["timings"]
                stage[who].append(timings["wall_s"])
                trees[who].append(timings["tree_s"])
            else:
                t = time.perf_counter()
                hit = mesh.ray.intersects_first(origins, directions)
                embree.append(time.perf_counter() - t)
    load = os.getloadavg()
    ms = lambda xs: 1e3 * statistics.median(xs)
    print(f"{os.path.basename(a.part)}: {len(mesh.faces)} facets, {int((hit >= 0).sum())} Embree hits")
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {a.runs} rounds, median ms")
    for who in binaries:
        ours, tree = stage[who], trees[who]
        name = "moldgate" if who == "moldgate" else "before  "
        print(f"  {name} wall-thickness stage {ms(ours):8.1f}   its ray tree {ms(tree):8.1f}")
    print(f"  Embree intersects_first       {ms(embree):8.1f}   its scene    {1e3 * scene_s:8.1f} (once)")
    for who in binaries:
        ours, tree = stage[who], trees[who]
        ratio = statistics.median(o / e for o, e in zip(ours, embree))
        both = statistics.median((o + t) / (e + scene_s) for o, t, e in zip(ours, tree, embree))
        print(f"  {who}: paired ratio stage / Embree rays {ratio:.2f}; "
              f"(tree + stage) / (scene + rays) {both:.2f}")
    if a.before:
        paired = lambda key: statistics.median(
            x / y for x, y in zip(key["moldgate"], key["before"]))
        print(f"  after / before, paired: stage {paired(stage):.3f}, tree {paired(trees):.3f}")


if __name__ == "__main__":
    main()
