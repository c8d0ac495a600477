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

// The root joint's rest-pose facing direction, expressed in the root joint's local frame. Unit
// length. In the rest pose all local rotations are identity, so every joint's frame is parallel
// to the root's and the same vector is the facing direction in any joint's frame (e.g. in Hips'
// frame for Bandai-Namco, whose joint 0 is a static joint_Root).
// Estimated from the left/right limb pair attached nearest the root (the hips; pairs found by
// name, see mirror_map; a pair sitting on one point, like CMU's LHipJoint/RHipJoint, is followed
// down to LeftUpLeg/RightUpLeg) and the body's up direction, taken from the pelvis along its
// unpaired child chain (the spine), or the skeleton's up axis when there is none:
//   forward = normalize((left - right) x body_up)
// (right-handed: a Y-up character facing +Z has its left at +X). Shoulders are not used: their
// rest positions go through spine joints whose rest frames may differ from the root's (in
// Bandai-Namco's rest pose the body lies along +X, the legs' left/right axis is Y and the
// shoulders' is Z). Falls back to the heading-0 direction (+Z for Y-up, +X for Z-up, +Y for
// X-up) when the skeleton has no left/right pairs. Throws mosyn::Error for an invalid skeleton.
// Verified on real data: Bandai-Namco gives about +Z in Hips' frame, CMU about +Z in Hips' frame,
// and walking clips then move forward along the heading.
Eigen::Vector3d estimate_forward_in_root(const Skeleton& skeleton);

// The coordinate of the facing direction at heading 0 and of the sideways direction (90 degrees
// counter-clockwise from it about up): RootDelta::forward and ::sideways lie along these axes in
// the character's ground frame (Y-up: 2 and 0).
int forward_axis(const Skeleton& skeleton);
int sideways_axis(const Skeleton& skeleton);

// Rotation by angle_rad about the skeleton's up axis.
Eigen::Quaterniond heading_rotation(const Skeleton& skeleton, double angle_rad);

// Heading angle (radians) of a world direction projected onto the floor.
double heading_of(const Skeleton& skeleton, const Eigen::Vector3d& direction);

// Ground trajectory of the joint root_joint (for Bandai-Namco, "Hips", whose parent is a
// static joint_Root): floor projection of its world position and heading of its world
// rotation applied to forward_in_root. Headings are unwrapped so they never jump by 2 pi.
GroundTrajectory ground_trajectory(const Skeleton& skeleton, const Motion& motion, int root_joint,
                                   const Eigen::Vector3d& forward_in_root);

// Gaussian low-pass of a trajectory (MoGlow Sec. 4.1: "Gaussian-filtering the horizontal,
// floor-projected hip motion"): positions and unwrapped headings are each convolved with a
// normalised Gaussian of standard deviation sigma_frames (frames), truncated at 4 sigma. The ends
// are extended by point reflection (x[-k] = 2 x[0] - x[k]), which keeps the velocity at a clip's
// first and last frames instead of forcing it to zero as mirror padding would. sigma_frames <= 0
// returns the trajectory unchanged. The up coordinate stays 0.
GroundTrajectory smooth_ground_trajectory(const GroundTrajectory& trajectory, double sigma_frames);

// Per-frame deltas of a trajectory ([T] entries, the first all zeros).
std::vector<RootDelta> root_deltas(const Skeleton& skeleton, const GroundTrajectory& trajectory);

// Inverse of root_deltas: integrates deltas from a start position and heading. Exact up to
// floating-point rounding: integrate_root_deltas(root_deltas(g), g.positions[0], g.headings_rad[0]) == g.
GroundTrajectory integrate_root_deltas(const Skeleton& skeleton, const std::vector<RootDelta>& deltas,
                                       const Eigen::Vector3d& start_position, double start_heading_rad);

}  // namespace mosyn
