// The root trajectory on the floor: the control signal of MoGlow and the recurrent VAE, and the
// velocity channels of DFN.
//
// Frame of reference: the floor is the plane orthogonal to the skeleton's up axis. A heading
// angle theta (radians, about the up axis, right-handed) describes where the character faces;
// for a Y-up skeleton theta = 0 faces +Z, and the facing direction is (sin theta, 0, cos theta).
// The character's own ground frame has its forward axis along the facing direction and its
// sideways axis 90 degrees counter-clockwise from it seen from above (for Y-up, theta = 0: +X).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "core/skeleton.h"

namespace mosyn {

// Per-frame root displacement expressed in the character's own ground frame of the previous
// frame: delta[t] moves frame t-1 to frame t; delta[0] is all zeros.
struct RootDelta {
  double sideways = 0;  // dx, skeleton units along the character's sideways axis
  double forward = 0;   // dz, skeleton units along the character's facing direction
  double turn_rad = 0;  // dtheta, change of heading about the up axis
};

// The floor-projected root path and heading, one entry per frame.
struct GroundTrajectory {
  std::vector<Eigen::Vector3d> positions;  // [T] root position with the up coordinate set to 0
  std::vector<double> headings_rad;        // [T] unwrapped (continuous) heading angles
};

// The root joint's rest-pose facing direction, expressed in the root joint's local frame,
// estimated from left/right hips and shoulders (name-based, see mirror_map) as
// up x (left - right), or +Z when the skeleton has no left/right pairs. Unit length.
Eigen::Vector3d estimate_forward_in_root(const Skeleton& skeleton);

// Rotation by angle_rad about the skeleton's up axis.
Eigen::Quaterniond heading_rotation(const Skeleton& skeleton, double angle_rad);

// Heading angle (radians) of a world direction projected onto the floor.
double heading_of(const Skeleton& skeleton, const Eigen::Vector3d& direction);

// Ground trajectory of the joint root_joint (for Bandai-Namco, "Hips", whose parent is a
// static joint_Root): floor projection of its world position and heading of its world
// rotation applied to forward_in_root. Headings are unwrapped so they never jump by 2 pi.
GroundTrajectory ground_trajectory(const Skeleton& skeleton, const Motion& motion, int root_joint,
                                   const Eigen::Vector3d& forward_in_root);

// Per-frame deltas of a trajectory ([T] entries, the first all zeros).
std::vector<RootDelta> root_deltas(const Skeleton& skeleton, const GroundTrajectory& trajectory);

// Inverse of root_deltas: integrates deltas from a start position and heading. Exact up to
// floating-point rounding: integrate_root_deltas(root_deltas(g), g.positions[0], g.headings_rad[0]) == g.
GroundTrajectory integrate_root_deltas(const Skeleton& skeleton, const std::vector<RootDelta>& deltas,
                                       const Eigen::Vector3d& start_position, double start_heading_rad);

}  // namespace mosyn
