// Rigs to retarget onto (core/retarget.h), read from BVH or glTF files, and retargeted motions
// written back in the rig's own format.
//
// - BVH: the hierarchy, OFFSETs (file units) and channel layout; the file's frames, if any, give
//   the reference pose of rigs whose rest pose does not stand; joints with position channels can
//   carry the hips' path.
// - glTF (.glb / .gltf): the joints of the first skin, or, without a skin, every node, in their
//   node hierarchy; each joint's rest transform is its node's translation and rotation (TRS or
//   matrix) with those of any non-joint ancestors (an "Armature" node's turn or scale) folded into
//   the root joint and the offsets, so world rest positions are exact. Lengths are metres, +Y up.
#pragma once

#include <optional>
#include <string>

#include "core/retarget.h"
#include "io/bvh.h"

namespace mosyn::io {

struct RigFile {
  RetargetRig rig;
  std::optional<BvhFile> bvh;   // the BVH file the rig came from (its channel layout)
  double meters_per_unit = 1;   // the rig's length unit: 1 for glTF, guessed for BVH (core/units.h)
};

// The rig of a glTF file's bytes (binary when `binary`). file_name_for_errors is used only in
// messages. Throws mosyn::ParseError naming the file for a malformed file, no joints, joints in
// more than one tree, repeated joint names or non-finite transforms.
RetargetRig parse_gltf_rig(const std::string& bytes, bool binary, const std::string& file_name_for_errors);

// A rig from a .bvh, .glb or .gltf file (by extension; anything else is mosyn::Error). Throws
// mosyn::Error naming the path when it cannot be read, ParseError when it is malformed.
RigFile read_rig(const std::string& path);

// Writes a motion on the rig: BVH with the rig's channel layout when it came from a BVH file (else
// the default layout, offsets in the rig's units), glTF (.glb / .gltf) in metres with the motion
// as one animation named `name`. Atomic. Throws mosyn::Error for another extension or a motion
// that does not fit the rig.
void write_on_rig(const std::string& path, const RigFile& rig, const Motion& motion, const std::string& name);

}  // namespace mosyn::io
