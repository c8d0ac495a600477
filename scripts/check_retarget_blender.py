"""Checks that Blender imports what `mosyn retarget` writes, BVH and glTF, with the motion intact.

Usage (Debian's blender 3.4; not part of `make test` because blender is large):
    build/mosyn retarget walk.bvh --to RIG.bvh --out on_rig.bvh
    build/mosyn retarget walk.bvh --to RIG.bvh --out on_rig.glb
    build/mosyn convert on_rig.bvh on_rig.json --positions
    build/mosyn convert on_rig.bvh on_rig_m.json --positions --metres
    blender -b --python scripts/check_retarget_blender.py -- on_rig.bvh on_rig.json on_rig.glb on_rig_m.json

Imports the BVH with Blender's own BVH importer (file units, its default axes: a BVH point
(x, y, z) is (x, -z, y) in Blender) and compares every bone's head with mosyn's joint positions at
a spread of frames; then runs scripts/check_gltf_blender.py on the glTF file. Exits 1 when a joint
is missing, the frame count differs, or a head is off by more than 1e-4 of the skeleton's size.
"""
import builtins
import json
import os
import sys

import bpy  # noqa: E402  (only inside blender)
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

# Blender 3.4's BVH importer opens files with mode 'rU', which Python 3.11 no longer accepts.
_open = builtins.open


def _open_without_u(file, mode="r", *args, **kwargs):
    return _open(file, mode.replace("U", "") if isinstance(mode, str) else mode, *args, **kwargs)


builtins.open = _open_without_u


def check_bvh(bvh_path, positions_json):
    expected = json.load(open(positions_json))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=bvh_path, global_scale=1.0, update_scene_fps=True, update_scene_duration=True)
    armatures = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    if not armatures:
        print("check_retarget_blender: no armature imported from", bvh_path)
        return 1
    arm = armatures[0]
    names = expected["joints"]
    missing = [n for n in names if n not in arm.pose.bones]
    if missing:
        print("check_retarget_blender: joints missing in the armature:", missing[:5])
        return 1
    frames = expected["positions"]
    scene = bpy.context.scene
    # The frames the importer keyed, from the action: it sets the scene's frame_end one past the
    # last frame, and only ever extends the scene (a clip under 250 frames keeps 250).
    action = arm.animation_data.action if arm.animation_data else None
    if action is None:
        print("check_retarget_blender: the armature has no action")
        return 1
    first, last = action.frame_range
    imported = int(round(last - first)) + 1
    if imported != len(frames):
        print(f"check_retarget_blender: {imported} frames imported, {len(frames)} written")
        return 1
    size = max(max(abs(c) for c in p) for p in frames[0])
    checked = sorted(set([0, len(frames) // 3, 2 * len(frames) // 3, len(frames) - 1]))
    best = None
    for offset in (0, 1):
        worst = 0.0
        for t in checked:
            scene.frame_set(int(round(first)) + t - 1 + offset)
            for j, name in enumerate(names):
                x, y, z = frames[t][j]
                head = arm.matrix_world @ arm.pose.bones[name].head
                worst = max(worst, (head - Vector((x, -z, y))).length)
        best = worst if best is None else min(best, worst)
    print(f"check_retarget_blender: BVH {len(names)} joints, {len(frames)} frames, largest distance to mosyn's FK "
          f"{best:.3g} file units (skeleton size {size:.3g})")
    return 0 if best <= 1e-4 * size else 1


def main(argv):
    bvh_path, bvh_json, glb, glb_json = argv
    if check_bvh(bvh_path, bvh_json) != 0:
        return 1
    import check_gltf_blender
    return check_gltf_blender.main([glb, glb_json])


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(args) != 4:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(args))
