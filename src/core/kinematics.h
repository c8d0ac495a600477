// Forward kinematics in double precision.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

// World-space transform of every joint at every frame, row-major [T, J].
struct WorldPoses {
  int num_frames = 0;
  int num_joints = 0;
  std::vector<Eigen::Quaterniond> rotations;  // [T, J] world orientation of each joint's frame
  std::vector<Eigen::Vector3d> positions;     // [T, J] world position, skeleton units

  const Eigen::Vector3d& position(int t, int j) const { return positions[static_cast<size_t>(t) * num_joints + j]; }
  const Eigen::Quaterniond& rotation(int t, int j) const { return rotations[static_cast<size_t>(t) * num_joints + j]; }
};

// World transforms: for the root, R_w = R_local, p_w = translation; for a child c of p,
// R_w(c) = R_w(p) * R_local(c) and p_w(c) = p_w(p) + R_w(p) * translation(c).
WorldPoses forward_kinematics(const Skeleton& skeleton, const Motion& motion);

// World positions [T, E] of the skeleton's end sites (in skeleton.end_sites order), given FK.
std::vector<Eigen::Vector3d> end_site_positions(const Skeleton& skeleton, const WorldPoses& poses);

}  // namespace mosyn
