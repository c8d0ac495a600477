// Feature representations of motion: how a clip becomes per-frame vectors for learning and how
// vectors become a clip again. Both forms use the same control signal, the per-frame root
// deltas of core/trajectory.h: control[t] = (dx, dz, dtheta) in metres and radians.
#pragma once

#include <string>
#include <vector>

#include "core/skeleton.h"

namespace mosyn::data {

enum class PoseForm {
  // Local joint rotations (6D, Zhou et al.) of every joint; the root's rotation relative to
  // its heading frame; plus the root's height above the floor (metres).
  kRotations,
  // Joint positions relative to the floor-projected root, in the root's heading frame (metres).
  // Back to rotations through an inverse-kinematics fit onto the skeleton.
  kPositions,
};

const char* to_string(PoseForm form);
// "rotations" or "positions"; throws mosyn::Error otherwise.
PoseForm parse_pose_form(const std::string& text);

// How a feature vector is laid out, written into dataset.json and run directories.
struct FeatureLayout {
  PoseForm form = PoseForm::kRotations;
  int root_joint = 0;       // index of the trajectory joint (Bandai-Namco: Hips once joint_Root is dropped)
  Eigen::Vector3d forward_in_root{0, 0, 1};  // rest facing in the root's frame (core/trajectory.h)
  int pose_dim = 0;
  int control_dim = 3;
  std::vector<std::string> pose_names;     // [pose_dim] human-readable names, e.g. "Hips.r6d0"
  std::vector<std::string> control_names;  // {"dx_m", "dz_m", "dtheta_rad"}
};

// Layout for a skeleton in a given form.
FeatureLayout make_layout(const Skeleton& skeleton, PoseForm form, int root_joint,
                          const Eigen::Vector3d& forward_in_root);

// Encodes a clip: pose [T, pose_dim] and control [T, control_dim], row-major float32.
void encode(const Skeleton& skeleton, const Motion& motion, const FeatureLayout& layout,
            std::vector<float>* pose, std::vector<float>* control);

// Decodes features back to a motion on the skeleton, integrating the control from the given
// start position (skeleton units, up coordinate ignored) and heading. For kPositions this fits
// joint rotations by inverse kinematics.
Motion decode(const Skeleton& skeleton, const FeatureLayout& layout, const float* pose, const float* control,
              int num_frames, double fps, const Eigen::Vector3d& start_position = Eigen::Vector3d::Zero(),
              double start_heading_rad = 0.0);

}  // namespace mosyn::data
