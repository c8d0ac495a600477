// The body fit of MOJO's recursive projection, solved by Ceres (Levenberg-Marquardt with automatic
// derivatives): the joint rotations and root translation of one frame whose surface markers best
// match given marker positions, near a start pose. Only this family links Ceres; the data layer
// decodes the marker pose form with the Eigen fit of core/markers.h, which solves the same problem.
#pragma once

#include <vector>

#include "core/markers.h"
#include "core/skeleton.h"

namespace mosyn::nn::mojo {

struct CeresFitOptions {
  int max_iterations = 10;  // Levenberg-Marquardt iterations (a warm start needs few)
  double pose_prior = 1e-4; // weight (metres^2 per radian^2) of the squared change of every local
                            // rotation away from the start pose, against squared marker errors in
                            // metres (the stand-in for the paper's VPoser prior and the
                            // frame-to-frame smoothness of its warm-started fit)
};

// Fits frame t of `motion` (the local rotation of every joint and the root's translation; the other
// translations stay) so that its markers match targets [M] (world, skeleton units), starting from
// the frame's current values. Parameters: a rotation increment per joint, q_j = q_j,start exp(d_j)
// (angle-axis d_j in the joint's local frame), and the root's translation. Residuals: marker
// differences in metres [3M] and sqrt(pose_prior) d_j [3J]. Returns the iterations taken, the
// RMS marker distance after the fit (skeleton units) and the fitted markers. Throws mosyn::Error
// when targets do not have one entry per marker or are not finite.
MarkerFitResult fit_markers_ceres(const Skeleton& skeleton, const MarkerSet& markers,
                                  const std::vector<Eigen::Vector3d>& targets, Motion* motion, int t,
                                  const CeresFitOptions& options = {});

}  // namespace mosyn::nn::mojo
