// Re-expressing a clip on a subset of its joints (e.g. dropping fingers, or reducing two
// datasets to a common skeleton) without changing where the kept joints are.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

// Indices of the joints with these exact names, in the order given. Throws mosyn::Error naming
// the first name the skeleton lacks.
std::vector<int> joint_indices(const Skeleton& skeleton, const std::vector<std::string>& names);

// True when name matches a glob pattern in which '*' stands for any run of characters
// (possibly empty) and '?' for one character; case-sensitive, everything else literal.
bool glob_match(const std::string& pattern, const std::string& name);

// Indices (ascending) of the joints whose name matches at least one pattern (glob_match).
std::vector<int> joints_matching(const Skeleton& skeleton, const std::vector<std::string>& patterns);

// Indices (ascending) of the joints whose name matches none of the patterns: the keep-list that
// drops the matching ones, e.g. joints_excluding(s, finger_joint_patterns()).
std::vector<int> joints_excluding(const Skeleton& skeleton, const std::vector<std::string>& patterns);

// Glob patterns that match finger joints of the usual BVH skeletons (CMU's LeftFingerBase,
// LeftHandIndex1, LThumb; "*Thumb*", "*Index*", "*Middle*", "*Ring*", "*Pinky*", "*Finger*" ...).
std::vector<std::string> finger_joint_patterns();

// The skeleton on the kept joints (any order, duplicates ignored; they are used in ascending
// order, so the depth-first order is preserved). The root (joint 0) must be kept, otherwise a
// mosyn::Error names it; an index out of range also throws. A kept joint's parent becomes its
// nearest kept ancestor and its offset the sum of the rest offsets along the dropped chain (the
// rest pose has identity rotations). End sites whose parent joint is kept are kept with their
// offset; end sites of dropped joints are dropped (their position depends on dropped rotations).
// meters_per_unit and up_axis are copied.
Skeleton subset_skeleton(const Skeleton& skeleton, const std::vector<int>& keep);

// The motion on the kept joints [T, K] (keep as for subset_skeleton). A kept joint c whose nearest
// kept ancestor is a, through dropped joints d1..dn (a -> d1 -> ... -> dn -> c), gets the composed
// local transform
//   R' = R(d1) ... R(dn) R(c),
//   t' = t(d1) + R(d1) t(d2) + ... + R(d1)...R(dn) t(c),
// so world rotations and positions of every kept joint are unchanged (up to rounding).
Motion subset_motion(const Skeleton& skeleton, const Motion& motion, const std::vector<int>& keep);

// subset_skeleton and subset_motion together.
Clip subset_clip(const Clip& clip, const std::vector<int>& keep);

}  // namespace mosyn
