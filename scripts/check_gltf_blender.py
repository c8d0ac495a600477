"""Checks that Blender imports a glTF file written by `mosyn convert` with the motion intact.

Usage (Debian's blender 3.4; the check is not part of `make test` because blender is large):
    build/mosyn convert walk.bvh walk.glb
    build/mosyn convert walk.bvh walk.json --positions --metres
    blender -b --python scripts/check_gltf_blender.py -- walk.glb walk.json

Imports the .glb with Blender's own glTF importer, plays its animation and compares the world
position of every bone's head (Blender is Z-up: a glTF/BVH point (x, y, z) is (x, -z, y) there)
with the joint positions mosyn computed, at a spread of frames. Prints the largest distance and
exits 1 when it exceeds 1 mm, or when a joint is missing, or the file has no armature.
"""
import json
import sys

import bpy  # noqa: E402  (only inside blender)
import numpy
from mathutils import Vector

# Debian 12's blender 3.4 importer uses numpy.bool, which Debian's numpy 1.24 no longer has.
if "bool" not in numpy.__dict__:
    numpy.bool = bool


def main(argv):
    glb, positions_json = argv
    expected = json.load(open(positions_json))
    fps = expected["fps"]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.render.fps = int(round(fps))
    bpy.context.scene.render.fps_base = bpy.context.scene.render.fps / fps
    bpy.ops.import_scene.gltf(filepath=glb)
    armatures = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    if not armatures:
        print("check_gltf_blender: no armature imported")
        return 1
    arm = armatures[0]
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    names = expected["joints"]
    missing = [n for n in names if n not in arm.pose.bones]
    if missing:
        print("check_gltf_blender: joints missing in the armature:", missing[:5])
        return 1
    frames = expected["positions"]
    checked = sorted(set([0, len(frames) // 3, 2 * len(frames) // 3, len(frames) - 1]))
    # Blender's importer may start the action at frame 0 or 1: take the offset that fits.
    best = None
    for offset in (0, 1):
        worst = 0.0
        for t in checked:
            bpy.context.scene.frame_set(t + offset)
            for j, name in enumerate(names):
                x, y, z = frames[t][j]
                head = arm.matrix_world @ arm.pose.bones[name].head
                worst = max(worst, (head - Vector((x, -z, y))).length)
        best = worst if best is None else min(best, worst)
    print(f"check_gltf_blender: {len(names)} joints, frames {checked}, {len(meshes)} mesh(es), "
          f"largest distance to mosyn's FK {best * 1000:.3f} mm")
    return 0 if best <= 1e-3 else 1


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(args) != 2:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(args))
