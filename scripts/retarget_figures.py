#!/usr/bin/python3
"""The figures by which `mosyn retarget` is judged (issue 60), measured independently of mosyn's
code with ../shared/checks/bvh.py and natural_motion.py: each input BVH is retargeted onto each
rig, then for every output

  limbs     world direction error (degrees) of thigh, shin, upper arm, forearm and spine
            (hips to neck) against the input's: mean over limbs and frames, worst limb's mean,
            and the largest single frame
  path      hips path length (horizontal) over the input's, beside the leg-length ratio
  skate     foot-skating ratio of output and input, each file in its own metres: natural_motion.py's
            (toe joints by name, else ankles: a rig with "ball" toes is measured on its ankles
            against the input's toes), and like for like (toes with toes, ankles with ankles)
  floor     5th-percentile height of the lowest foot joint, output vs input scaled (cm)

    scripts/retarget_figures.py --mosyn build/mosyn --rig CMU.bvh --rig apose --out DIR IN.bvh...

`--rig apose` writes a hand-made rig (Unreal-mannequin names, A-pose arms, twist joints, longer
legs, a ground root carrying the path) to DIR/apose_rig.bvh. Needs Debian's python3-numpy.
"""
import argparse
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CHECKS = os.path.join(HERE, "..", "..", "shared", "checks")
sys.path.insert(0, CHECKS)
import bvh  # noqa: E402

# limb -> candidate (start, end) joint names, per convention
LIMBS = {
    "thigh_l": [("UpperLeg_L", "LowerLeg_L"), ("LeftUpLeg", "LeftLeg"), ("thigh_l", "calf_l")],
    "shin_l": [("LowerLeg_L", "Foot_L"), ("LeftLeg", "LeftFoot"), ("calf_l", "foot_l")],
    "thigh_r": [("UpperLeg_R", "LowerLeg_R"), ("RightUpLeg", "RightLeg"), ("thigh_r", "calf_r")],
    "shin_r": [("LowerLeg_R", "Foot_R"), ("RightLeg", "RightFoot"), ("calf_r", "foot_r")],
    "upperarm_l": [("UpperArm_L", "LowerArm_L"), ("LeftArm", "LeftForeArm"), ("upperarm_l", "lowerarm_l")],
    "forearm_l": [("LowerArm_L", "Hand_L"), ("LeftForeArm", "LeftHand"), ("lowerarm_l", "hand_l")],
    "upperarm_r": [("UpperArm_R", "LowerArm_R"), ("RightArm", "RightForeArm"), ("upperarm_r", "lowerarm_r")],
    "forearm_r": [("LowerArm_R", "Hand_R"), ("RightForeArm", "RightHand"), ("lowerarm_r", "hand_r")],
    "spine": [("Hips", "Neck"), ("pelvis", "neck_01")],
}
HIPS = ["Hips", "pelvis"]
FEET = [["Toes_L", "Toes_R", "Foot_L", "Foot_R"], ["LeftToeBase", "RightToeBase", "LeftFoot", "RightFoot"],
        ["ball_l", "ball_r", "foot_l", "foot_r"]]  # toes, then ankles
sys.path.insert(0, CHECKS)
import natural_motion  # noqa: E402
SCALES = {"cm": 0.01, "cmu": 0.056444}

APOSE_RIG = """HIERARCHY
ROOT root
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT pelvis
\t{
\t\tOFFSET 0 103 0
\t\tCHANNELS 3 Xrotation Yrotation Zrotation
%(spine)s
%(legs)s
\t}
}
MOTION
Frames: 1
Frame Time: 0.0333333
%(zeros)s
"""


def apose_rig_text():
    """A hand-made rig: other names, an A-pose (arms 40 degrees down), twist joints, other proportions."""
    joints = []  # (depth, name, offset, end offset or None)
    c, s = np.cos(np.radians(40)), np.sin(np.radians(40))
    spine = [(2, "spine_01", (0, 8, 0)), (3, "spine_02", (0, 11, 0)), (4, "spine_03", (0, 11, 0)),
             (5, "neck_01", (0, 15, 0)), (6, "head", (0, 9, 0), (0, 17, 0))]
    for side, x in (("l", 1), ("r", -1)):
        spine += [(5, "clavicle_" + side, (x * 4, 11, 1)), (6, "upperarm_" + side, (x * 14, 0, 0)),
                  (7, "upperarm_twist_01_" + side, (x * 13 * c, -13 * s, 0), None),
                  (7, "lowerarm_" + side, (x * 27 * c, -27 * s, 0)),
                  (8, "hand_" + side, (x * 25 * c, -25 * s, 0), (x * 9 * c, -9 * s, 0))]
    legs = []
    for side, x in (("l", 1), ("r", -1)):
        legs += [(2, "thigh_" + side, (x * 10, -5, 0)), (3, "calf_" + side, (0, -48, 0)),
                 (4, "foot_" + side, (0, -45, 0)), (5, "ball_" + side, (0, -8, 13), (0, 0, 6))]

    def block(items):
        out, stack = [], []
        for item in items:
            depth, name, off = item[:3]
            while stack and stack[-1] >= depth:
                out.append("\t" * stack.pop() + "}")
            t = "\t" * depth
            out += [t + "JOINT " + name, t + "{", t + "\tOFFSET %g %g %g" % off,
                    t + "\tCHANNELS 3 Xrotation Yrotation Zrotation"]
            stack.append(depth)
            if len(item) > 3:  # a leaf
                if item[3] is not None:
                    out += [t + "\tEnd Site", t + "\t{", t + "\t\tOFFSET %g %g %g" % item[3], t + "\t}"]
        while stack:
            out.append("\t" * stack.pop() + "}")
        return "\n".join(out)

    n_channels = 6 + 3 + 3 * (len(spine) + len(legs))
    return APOSE_RIG % {"spine": block(spine), "legs": block(legs), "zeros": " ".join(["0"] * n_channels)}


def load(path):
    joints, vals, ft = bvh.read(path)
    return [j.name for j in joints], bvh.world_positions(joints, vals), 1.0 / ft


def index(names, candidates):
    for c in candidates:
        if c in names:
            return names.index(c)
    raise SystemExit("none of %s in %s" % (candidates, names))


def limb(names, key):
    for a, b in LIMBS[key]:
        if a in names and b in names:
            return names.index(a), names.index(b)
    raise SystemExit("no %s in %s" % (key, names))


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def leg_length(names, pos):
    total = 0
    for key in ("thigh_l", "shin_l", "thigh_r", "shin_r"):
        a, b = limb(names, key)
        total += np.linalg.norm(pos[0, b] - pos[0, a])
    return total / 2


def skating(path, scale):
    out = subprocess.run([sys.executable, os.path.join(CHECKS, "natural_motion.py"), "--scale", str(scale), path,
                          "--real", path], capture_output=True, text=True, check=True).stdout
    return float(re.search(r"skating\s+generated\s+([0-9.naninf]+)", out).group(1))


def like_for_like_skating(path, scale):
    """natural_motion's skating ratio of the toes and of the ankles (FEET), each file in metres."""
    pos, names, fps = natural_motion.positions_m(path, scale)
    feet = next(f for f in FEET if all(n in names for n in f))
    return tuple(natural_motion.foot_skating_ratio(pos, [names.index(n) for n in pair], fps)
                 for pair in (feet[:2], feet[2:]))


def floor_height(names, pos):
    feet = next(f for f in FEET if all(n in names for n in f))
    low = pos[:, [names.index(n) for n in feet], 1].min(axis=1)
    return float(np.percentile(low, 5))


def measure(inp, out, in_scale, out_scale):
    ni, pi, _ = load(inp)
    no, po, _ = load(out)
    errors = {}
    for key in LIMBS:
        a, b = limb(ni, key)
        c, d = limb(no, key)
        cos = np.clip((unit(pi[:, b] - pi[:, a]) * unit(po[:, d] - po[:, c])).sum(-1), -1, 1)
        errors[key] = np.degrees(np.arccos(cos))
    k = leg_length(no, po) / leg_length(ni, pi)
    hi, ho = index(ni, HIPS), index(no, HIPS)
    path_i = np.linalg.norm(np.diff(pi[:, hi][:, [0, 2]], axis=0), axis=1).sum()
    path_o = np.linalg.norm(np.diff(po[:, ho][:, [0, 2]], axis=0), axis=1).sum()
    floor_cm = (floor_height(no, po) - k * floor_height(ni, pi)) * out_scale * 100
    return {
        "frames": (len(pi), len(po)),
        "limb_mean_deg": float(np.mean([e.mean() for e in errors.values()])),
        "worst_limb_mean_deg": max((float(e.mean()), key) for key, e in errors.items()),
        "largest_frame_deg": max((float(e.max()), key) for key, e in errors.items()),
        "leg_ratio": k,
        "path_ratio_over_leg_ratio": path_o / path_i / k,
        "skate_out": skating(out, out_scale),
        "skate_in": skating(inp, in_scale),
        "skate_toes_ankles_out": like_for_like_skating(out, out_scale),
        "skate_toes_ankles_in": like_for_like_skating(inp, in_scale),
        "floor_diff_cm": floor_cm,
    }


def units_of(path):
    """Metres per file unit: CMU units for CMU-named skeletons, else centimetres (Bandai-Namco)."""
    joints, _, _ = bvh.read(path)
    return SCALES["cmu"] if any(j.name == "LeftUpLeg" for j in joints) else SCALES["cm"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("inputs", nargs="+", help="input BVH files (Bandai-Namco in centimetres, or CMU)")
    ap.add_argument("--mosyn", default="build/mosyn")
    ap.add_argument("--rig", action="append", required=True, help="a rig BVH (CMU or Bandai-Namco) or 'apose'")
    ap.add_argument("--out", required=True, help="folder for the retargeted files")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    failed = False
    for rig in a.rig:
        rig_scale = SCALES["cmu"]
        if rig == "apose":
            rig = os.path.join(a.out, "apose_rig.bvh")
            with open(rig, "w") as f:
                f.write(apose_rig_text())
            rig_scale = SCALES["cm"]
        for inp in a.inputs:
            out = os.path.join(a.out, os.path.basename(inp)[:-4] + "_on_" + os.path.basename(rig))
            subprocess.run([a.mosyn, "retarget", inp, "--to", rig, "--out", out], check=True)
            m = measure(inp, out, units_of(inp), units_of(rig) if rig_scale != SCALES["cm"] else rig_scale)
            skates = all(o <= 1.3 * i + 0.02 for o, i in zip(m["skate_toes_ankles_out"], m["skate_toes_ankles_in"]))
            ok = (m["limb_mean_deg"] <= 8 and m["worst_limb_mean_deg"][0] <= 15 and
                  abs(m["path_ratio_over_leg_ratio"] - 1) <= 0.1 and skates and abs(m["floor_diff_cm"]) <= 2)
            failed |= not ok
            print("%s  %s" % ("ok  " if ok else "FAIL", out))
            for key, value in m.items():
                print("    %-26s %s" % (key, value))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
