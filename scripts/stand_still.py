#!/usr/bin/python3
"""How far a body drifts when told to stand: for each BVH given, the largest horizontal distance
(metres) of the hips (the root joint, or the joint named Hips) from where they were in the first
frame. A sample of `mosyn sample MODEL --path "0,0" --seconds 10` (real time: add --realtime) keeps
its root at the origin, so this is how far the body left its root.

    scripts/stand_still.py SAMPLE.bvh... [--scale 0.01]

Prints one line per file and the worst; exit code 0. Needs Debian's python3-numpy and the
independent check's BVH reader (../shared/checks/bvh.py).
"""
import argparse, os, sys
import numpy as np

sys.path.insert(0, os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "checks")))
import bvh  # noqa: E402


def drift_m(path, scale):
    joints, values, _ = bvh.read(path)
    pos = bvh.world_positions(joints, values) * scale
    names = [j.name for j in joints]
    hips = names.index("Hips") if "Hips" in names else 0
    xz = pos[:, hips, [0, 2]]
    return float(np.linalg.norm(xz - xz[0], axis=1).max())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("files", nargs="+")
    ap.add_argument("--scale", type=float, default=0.01)
    a = ap.parse_args()
    worst = 0.0
    for f in a.files:
        d = drift_m(f, a.scale)
        worst = max(worst, d)
        print(f"{os.path.basename(f)}: hips drift {d:.3f} m")
    print(f"worst: {worst:.3f} m")


if __name__ == "__main__":
    main()
