#!/usr/bin/python3
"""How closely samples walk a drawn path: for each BVH of `mosyn sample MODEL --path "x,z ..."`
(the path starting at 0,0, as mosyn places it), the hips' ground track against the polyline
through the waypoints (metres): the largest and the mean distance of the track from the polyline,
and how far the last frame ends from the last waypoint.

    scripts/path_follow.py "0,0 0,3 2,5" SAMPLE.bvh... [--scale 0.01]

Pauses ("x,z,s") are allowed and ignored. Needs Debian's python3-numpy and the independent check's
BVH reader (../shared/checks/bvh.py).
"""
import argparse, os, sys
import numpy as np

sys.path.insert(0, os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "checks")))
import bvh  # noqa: E402


def polyline(text):
    pts = [tuple(float(v) for v in p.split(",")[:2]) for p in text.replace(";", " ").split()]
    return np.array(pts)


def distance_to_polyline(p, line):
    """Distance of each point p [N, 2] to the polyline [M, 2]."""
    best = np.full(len(p), np.inf)
    for a, b in zip(line[:-1], line[1:]):
        ab = b - a
        t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-12), 0, 1)
        best = np.minimum(best, np.linalg.norm(p - (a + t[:, None] * ab), axis=1))
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("path")
    ap.add_argument("files", nargs="+")
    ap.add_argument("--scale", type=float, default=0.01)
    a = ap.parse_args()
    line = polyline(a.path)
    if len(line) == 1:
        line = np.vstack([line, line])
    worst = 0.0
    for f in a.files:
        joints, values, _ = bvh.read(f)
        pos = bvh.world_positions(joints, values) * a.scale
        names = [j.name for j in joints]
        hips = names.index("Hips") if "Hips" in names else 0
        track = pos[:, hips][:, [0, 2]]
        d = distance_to_polyline(track, line)
        end = float(np.linalg.norm(track[-1] - line[-1]))
        worst = max(worst, float(d.max()))
        print(f"{os.path.basename(f)}: max {d.max():.3f} m, mean {d.mean():.3f} m from the path; ends {end:.3f} m from its end")
    print(f"worst: {worst:.3f} m")


if __name__ == "__main__":
    main()
