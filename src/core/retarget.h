// Retargeting: a motion of one skeleton (the input) played on another (the rig), on the rig's
// own hierarchy, offsets and rest pose.
//
// How it works:
// - Joints are paired by name (core/joint_names.h) or by an explicit map.
// - Reference poses: each skeleton's rest pose when it stands (legs down, spine up), else the
//   frame of its own motion that stands with both feet lowest (rigs with Maya-style joint
//   orients, whose rest pose has every bone along x, as Bandai-Namco's). The rig's reference pose
//   is bent, bone by bone, so that every paired bone points along the input's in the input's
//   reference pose (turned to face the rig's way); feet keep their world orientation (both stand
//   flat). That fixes, per paired joint, the constant rotation between the two skeletons' joint
//   frames (T-pose, A-pose and joint orients all cancel in world space).
// - Each frame, a paired joint takes the input joint's world rotation through that constant
//   rotation, then swings so its bone (to the next paired joint below it) points exactly where
//   the input's does. Feet are not aimed (rigs differ in foot length and ankle height): they turn
//   as the input's do from its reference pose, flat stays flat. Unpaired rig joints keep their
//   reference (rest) local rotation.
// - The hip sockets' midpoint (so a hips joint higher above the legs changes nothing) travels the
//   input's path scaled by the leg-length ratio (rig / input: hip to knee to ankle), raised by the
//   difference of the ankles' heights above the toe joints (rig minus input, scaled; in the
//   reference poses).
// - Feet: contacts are found on the input's ankles (core/foot_lock.h find_contacts); during a
//   contact the rig's ankle is pinned by two-bone IK (reach_with_leg), blended in and out:
//   horizontally to one point (its own position over the contact, weighted to where the input's
//   ankle is stillest), vertically to the input's ankle height, scaled and raised. While the
//   input's toe is down (contacts found on it likewise), the rig's toe is pinned the same way,
//   rising as the input's does, so the foot pivots about its toe as the heel lifts. Last, the
//   whole body moves up or down so the rig's feet (ankles, toes) stand where the input's do over
//   the take (5th percentile of the lowest), scaled.
//
// Both skeletons must share the up axis (Skeleton::up_axis). Lengths stay in each skeleton's own
// units: the scale between them comes from the leg lengths, so units cancel.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/foot_lock.h"
#include "core/skeleton.h"

namespace mosyn {

// The skeleton to retarget onto, as a rig file holds it.
struct RetargetRig {
  Skeleton skeleton;
  // [J] local rest rotations (w, x, y, z) of the rig's joints (glTF node rotations); empty means
  // identity for every joint (BVH).
  std::vector<Eigen::Quaterniond> rest_rotations;
  // Frames of the rig's own file, if any (num_frames may be 0): where the rest pose does not
  // stand, the frame standing with both feet lowest is its reference pose.
  Motion frames;
  // [J] whether the rig can animate a joint's translation (BVH position channels); empty means
  // every joint can. The hips path goes to the hips when they can move, else to the root.
  std::vector<bool> translatable;
};

struct RetargetOptions {
  std::map<std::string, std::string> joint_map;  // rig joint name -> input joint name (wins over names)
  bool plant_feet = true;                        // two-bone IK on the input's contacts
  FootLockOptions contacts;                      // contact detection on the input's ankles
};

struct RetargetReport {
  double scale = 1.0;  // rig length units per input length unit (leg-length ratio)
  // Rig units along up added to the scaled path: the rig's ankle height above its toe joints minus
  // the input's, scaled, so the toes of both stand on one floor.
  double lift = 0.0;
  std::vector<std::pair<std::string, std::string>> pairs;  // (rig joint, input joint) in rig order
  bool input_rest_reference = true;  // false: a frame of the input served as its reference pose
  bool rig_rest_reference = true;    // false: a frame of the rig's file did
  int contacts = 0;                  // contact intervals planted, over all legs
};

// The motion on the rig: [T, J_rig] local rotations and translations (rig units), the input's
// frames and fps. `source` and `motion` are the input (any units). Throws mosyn::Error when the
// motion does not fit its skeleton or is not finite, the rig is invalid, the joints cannot be
// paired (core/joint_names.h match_joints names them), a skeleton has neither a standing rest pose
// nor a standing frame, or the up axes differ.
Motion retarget(const Skeleton& source, const Motion& motion, const RetargetRig& rig,
                const RetargetOptions& options = {}, RetargetReport* report = nullptr);

struct RetargetPlan;  // the pairing and alignment (retarget.cpp)

// Frame-by-frame retargeting for motions made as they play (a generator behind the C ABI): each
// frame's rotations and hips path exactly as retarget() computes them with plant_feet off (the
// contacts need the whole take; a StreamingFootLock on the rig can pin feet causally).
class StreamingRetarget {
 public:
  // `reference`: frames of the input (e.g. the first generated ones) among which a standing one
  // aligns it when its rest pose does not stand; any frames of its skeleton otherwise. Throws as
  // retarget() does.
  StreamingRetarget(const Skeleton& source, const Motion& reference, const RetargetRig& rig,
                    const RetargetOptions& options = {});
  // One frame of the input ([1, J_input]) on the rig ([1, J_rig], rig units). Throws mosyn::Error
  // for a frame that is not one frame of the input's joints, or not finite.
  Motion apply(const Motion& frame) const;
  const Skeleton& rig_skeleton() const { return rig_.skeleton; }
  double scale() const { return scale_; }  // rig units per input unit

 private:
  RetargetRig rig_;
  std::shared_ptr<const RetargetPlan> plan_;
  double scale_ = 1;
};

}  // namespace mosyn
