// MOJO's Ceres body fit (nn/mojo/ceres_fit.h): it recovers a body from its own markers, agrees with
// the Eigen fit of core/markers.h on the same problem, its pose-change prior pulls towards the start
// pose, and bad targets are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/markers.h"
#include "core/rotation.h"
#include "core/synthetic.h"
#include "nn/mojo/ceres_fit.h"

using namespace mosyn;

namespace {

// Frame t of the synthetic walk as a one-frame motion.
Motion frame_of(const Motion& walk, int t) {
  Motion m = walk;
  m.num_frames = 1;
  const auto j = static_cast<size_t>(walk.num_joints);
  m.rotations.assign(walk.rotations.begin() + t * j, walk.rotations.begin() + (t + 1) * j);
  m.translations.assign(walk.translations.begin() + t * j, walk.translations.begin() + (t + 1) * j);
  return m;
}

// Every joint rotated by up to `angle` radians about a random axis, the root moved by up to 5 units.
Motion disturbed(const Motion& m, double angle, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Motion out = m;
  for (int j = 0; j < m.num_joints; ++j) {
    const Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    out.rotation(0, j) = (m.rotation(0, j) * quat_from_expmap(axis.normalized() * angle * std::abs(u(rng)))).normalized();
  }
  out.translation(0, 0) += Eigen::Vector3d(5 * u(rng), 5 * u(rng), 5 * u(rng));
  return out;
}

double max_joint_distance(const Skeleton& s, const Motion& a, const Motion& b) {
  const WorldPoses wa = forward_kinematics(s, a), wb = forward_kinematics(s, b);
  double worst = 0.0;
  for (int j = 0; j < s.num_joints(); ++j) worst = std::max(worst, (wa.position(0, j) - wb.position(0, j)).norm());
  return worst;
}

}  // namespace

TEST(MojoCeresFit, RecoversABodyFromItsOwnMarkersFromTheNeighbouringFrame) {
  const Skeleton s = make_synthetic_biped();
  const MarkerSet set = cmu41_markers(s);
  const Motion walk = make_synthetic_walk(s, 20, 30.0);
  for (int t = 1; t < walk.num_frames; t += 6) {
    const Motion truth = frame_of(walk, t);
    Motion fit = frame_of(walk, t - 1);  // the warm start of the projection: the previous frame's body
    nn::mojo::CeresFitOptions options;
    options.pose_prior = 0.0;
    options.max_iterations = 50;
    const MarkerFitResult r = nn::mojo::fit_markers_ceres(s, set, marker_positions(s, set, truth), &fit, 0, options);
    EXPECT_LT(r.rms_error, 1e-6) << "frame " << t;
    EXPECT_LT(max_joint_distance(s, truth, fit), 1e-4) << "frame " << t;
    EXPECT_GT(r.iterations, 0);
  }
}

TEST(MojoCeresFit, AgreesWithTheEigenFitFromADisturbedStart) {
  const Skeleton s = make_synthetic_biped();
  const MarkerSet set = cmu41_markers(s);
  const Motion truth = frame_of(make_synthetic_walk(s, 10, 30.0), 7);
  const auto targets = marker_positions(s, set, truth);
  for (unsigned seed = 1; seed <= 3; ++seed) {
    Motion by_ceres = disturbed(truth, 0.3, seed), by_eigen = by_ceres;
    nn::mojo::CeresFitOptions ceres_options;
    ceres_options.pose_prior = 1e-4;
    ceres_options.max_iterations = 100;
    MarkerFitOptions eigen_options;
    eigen_options.pose_prior = 1e-4;
    eigen_options.max_iterations = 100;
    const MarkerFitResult a = nn::mojo::fit_markers_ceres(s, set, targets, &by_ceres, 0, ceres_options);
    const MarkerFitResult b = fit_markers(s, set, targets, &by_eigen, 0, eigen_options);
    // Same problem, same minimum: the bodies agree to well under a millimetre-equivalent of the
    // skeleton's units, and both fit the markers closely.
    EXPECT_LT(max_joint_distance(s, by_ceres, by_eigen), 0.05) << "seed " << seed;
    EXPECT_LT(a.rms_error, 0.5) << "seed " << seed;
    EXPECT_NEAR(a.rms_error, b.rms_error, 0.05) << "seed " << seed;
    // Each returns the markers of the body it fitted, as forward kinematics places them.
    for (const auto& [fit, body] : {std::pair{&a, &by_ceres}, std::pair{&b, &by_eigen}}) {
      const auto expected = marker_positions(s, set, *body);
      ASSERT_EQ(fit->fitted.size(), expected.size());
      for (size_t i = 0; i < expected.size(); ++i)
        EXPECT_LT((fit->fitted[i] - expected[i]).norm(), 1e-9) << "seed " << seed << " marker " << i;
    }
  }
}

TEST(MojoCeresFit, PosePriorPullsTowardsTheStartPose) {
  const Skeleton s = make_synthetic_biped();
  const MarkerSet set = cmu41_markers(s);
  const Motion walk = make_synthetic_walk(s, 12, 30.0);
  const Motion start = frame_of(walk, 0), truth = frame_of(walk, 10);
  const auto targets = marker_positions(s, set, truth);
  double previous_change = -1.0, previous_rms = -1.0;
  for (double prior : {0.0, 1e-3, 1e-1}) {
    Motion fit = start;
    nn::mojo::CeresFitOptions options;
    options.pose_prior = prior;
    options.max_iterations = 100;
    const MarkerFitResult r = nn::mojo::fit_markers_ceres(s, set, targets, &fit, 0, options);
    double change = 0.0;
    for (int j = 0; j < s.num_joints(); ++j) change += geodesic_angle(fit.rotation(0, j), start.rotation(0, j));
    if (previous_change >= 0) {
      EXPECT_LT(change, previous_change) << "prior " << prior;  // a stronger prior moves less ...
      EXPECT_GT(r.rms_error, previous_rms) << "prior " << prior;  // ... and fits the markers less closely
    }
    previous_change = change;
    previous_rms = r.rms_error;
  }
}

TEST(MojoCeresFit, RefusesBadTargets) {
  const Skeleton s = make_synthetic_biped();
  const MarkerSet set = cmu41_markers(s);
  Motion fit = Motion::rest(s, 1, 30.0);
  auto targets = marker_positions(s, set, fit);
  targets.pop_back();
  EXPECT_THROW(nn::mojo::fit_markers_ceres(s, set, targets, &fit, 0), Error);
  targets = marker_positions(s, set, fit);
  targets[3].x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(nn::mojo::fit_markers_ceres(s, set, targets, &fit, 0), Error);
  targets = marker_positions(s, set, fit);
  EXPECT_THROW(nn::mojo::fit_markers_ceres(s, set, targets, &fit, 1), Error);  // frame out of range
}
