// glTF 2.0 export of motions (Debian's libtinygltf-dev serialises the model): the skeleton as a
// skin, a mesh of one capsule per bone rigidly bound to it so any viewer shows a body, and each
// motion as one animation, for Blender, game engines and three.js.
//
// Conventions of the written file (what glTF requires): metres, +Y up, right-handed.
// - One node per joint, named as the BVH joint, in the skeleton's hierarchy. A node's translation
//   is the joint's offset (metres), its rotation the joint's local rotation as glTF stores
//   quaternions: (x, y, z, w). A skeleton with another up axis is turned to +Y up by a rotation
//   folded into the root joint (render/scene.h to_y_up: Z-up (x, y, z) -> (x, z, -y)), so world
//   joint positions are exactly to_y_up(FK * metres_per_unit).
// - The skin lists the joints in skeleton order; its inverse bind matrices are those of the rest
//   pose (identity local rotations, root at the origin), in which the mesh is built.
// - The mesh: a capsule around every bone (joint to child joint or End Site), every vertex bound
//   with weight 1 to the bone's parent joint, so the body moves rigidly with the skeleton.
// - Animation i ("name"): for every joint a rotation channel (LINEAR, one key per frame at
//   t / fps seconds, consecutive quaternions in the same hemisphere), the root's translation, and
//   the translation of any other joint whose position is animated.
// - The nodes' own transforms are the first frame of the first motion, so viewers that do not
//   play animations show a natural pose.
// Every accessor carries exact min/max bounds (glTF requires them for positions and animation
// inputs; Blender's importer reads them).
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::io {

// One motion of the skeleton, written as one named glTF animation.
struct GltfMotion {
  std::string name;
  Motion motion;  // [T, J] on the skeleton given to write_gltf
};

struct GltfOptions {
  double meters_per_unit = 0;   // > 0: as given; 0: core/units.h resolve_meters_per_unit(skeleton)
  double limb_radius_m = 0.04;  // capsule radius, at most 0.4 of a bone's length
  int capsule_segments = 12;    // vertices around a capsule ring
  int capsule_rings = 4;        // rings of each half-sphere cap
};

// The whole file's bytes: binary glTF (.glb) when binary, else glTF JSON with the buffer
// embedded as a base64 data URI (one self-contained file). Throws mosyn::Error when there is no
// motion, a motion does not match the skeleton (joint count), has no frames or fps <= 0, or a
// value is not finite.
std::string gltf_bytes(const Skeleton& skeleton, const std::vector<GltfMotion>& motions, bool binary,
                       const GltfOptions& options = {});

// gltf_bytes written atomically (io/atomic_file.h); binary when path ends in ".glb", JSON when it
// ends in ".gltf" (anything else: mosyn::Error).
void write_gltf(const std::string& path, const Skeleton& skeleton, const std::vector<GltfMotion>& motions,
                const GltfOptions& options = {});

}  // namespace mosyn::io
