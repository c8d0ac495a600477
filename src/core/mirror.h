// Left/right symmetry of a skeleton and mirroring of motions (data augmentation, and the
// left/right pairs that trajectory.h uses to find where a character faces).
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

// Partner of every joint [J] found from names: the joint whose name differs only by a left/right
// marker. Recognised markers (case as written): prefixes and suffixes "Left"/"Right",
// "left"/"right", "LEFT"/"RIGHT" (LeftArm, HandLeft, left_foot), the tokens " L ", "_L_", ".L."
// and their lowercase forms inside a name ("Bip01 L Thigh"), and a single letter "L"/"R" or
// "l"/"r" as prefix or suffix (LHipJoint, Hand_L, Hand.L, l_eye). Rules are tried in that order
// and the first whose swapped name exists in the skeleton wins, so "LowerBack" stays unpaired
// unless a "RowerBack" exists. Only mutual pairs with opposite sides count; joints without a
// partner map to themselves. The map is an involution: map[map[j]] == j.
std::vector<int> mirror_map(const Skeleton& skeleton);

// Side of every joint [J]: +1 for the left joint of a pair found by mirror_map, -1 for the right
// one, 0 for unpaired joints.
std::vector<int> joint_sides(const Skeleton& skeleton);

// The horizontal axis whose orthogonal plane is a character's usual plane of symmetry in the
// rest pose: X for Y-up (the sideways axis of trajectory.h), Y for Z-up, Z for X-up.
int default_mirror_axis(const Skeleton& skeleton);

// Largest |offset[j] - S offset[map[j]]| over joints, in skeleton units, where S reflects
// mirror_axis: 0 for a skeleton whose rest pose (identity rotations) is exactly symmetric about the
// plane orthogonal to mirror_axis. mirror_motion is exact (world positions reflect) only then.
double mirror_asymmetry(const Skeleton& skeleton, const std::vector<int>& map, int mirror_axis);

// The motion reflected across the plane through the origin orthogonal to mirror_axis (0, 1, 2),
// with left and right joints swapped (map from mirror_map), on the same skeleton. With S the
// reflection, joint j of the result takes joint map[j] of the input:
//   rotation'    = S R S              (quaternion: keep w and the mirror_axis component, negate
//                                      the other two; e.g. (w, x, -y, -z) for X)
//   translation' = S t               for the root,
//   translation' = S (t - offset[map[j]]) + offset[j]   for other joints (the animated displacement
//                                      is mirrored, bone lengths stay the skeleton's own).
// When the skeleton is symmetric (mirror_asymmetry == 0) world positions of the result are exactly
// the reflected positions of the input with left/right swapped. When it is not, the result is the
// usual approximation: mirrored rotations on slightly different bone offsets. Skeletons whose joint
// frames are not aligned left vs right in the rest pose (Bandai-Namco's lies along +X with arms
// pointing opposite ways) need a per-joint frame correction that this function does not make:
// check mirror_asymmetry first. Mirroring twice returns the input (up to rounding in translations).
// Throws mosyn::Error when sizes disagree, map is not an involution, or mirror_axis is not 0..2.
Motion mirror_motion(const Skeleton& skeleton, const Motion& motion, const std::vector<int>& map, int mirror_axis);

}  // namespace mosyn
