#include "core/synthetic.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/mirror.h"

namespace mosyn {
namespace {

TEST(Synthetic, BipedIsAValidSymmetricYUpSkeletonInCentimetres) {
  const Skeleton s = make_synthetic_biped();
  EXPECT_NO_THROW(s.validate());
  EXPECT_EQ(s.num_joints(), 21);
  EXPECT_EQ(s.up_axis, 1);
  EXPECT_EQ(s.meters_per_unit, 0.01);
  EXPECT_EQ(s.end_sites.size(), 5u);
  EXPECT_EQ(s.joint_names[0], "Hips");
  EXPECT_EQ(s.find("Toes_R"), 20);
  EXPECT_EQ(mirror_asymmetry(s, mirror_map(s), 0), 0.0);
  // Rest pose: toes' end sites on the floor, head top 1.66 m up, left hand at +X.
  const WorldPoses rest = forward_kinematics(s, Motion::rest(s, 1, 30));
  const auto sites = end_site_positions(s, rest);
  EXPECT_NEAR(sites[3].y(), 0.0, 1e-12);
  EXPECT_NEAR(sites[4].y(), 0.0, 1e-12);
  EXPECT_NEAR(sites[0].y(), 166.0, 1e-9);
  EXPECT_GT(sites[1].x(), 50.0);
  EXPECT_LT(sites[2].x(), -50.0);
}

TEST(Synthetic, WalkIsDeterministicAndFinite) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.noise_rad = 0.03;
  o.seed = 5;
  const Motion a = make_synthetic_walk(s, 100, 30, o), b = make_synthetic_walk(s, 100, 30, o);
  EXPECT_NO_THROW(a.validate());
  EXPECT_EQ(a.num_frames, 100);
  EXPECT_EQ(a.num_joints, 21);
  EXPECT_EQ(a.fps, 30);
  for (size_t i = 0; i < a.rotations.size(); ++i) {
    EXPECT_EQ(a.rotations[i].coeffs(), b.rotations[i].coeffs());
    EXPECT_EQ(a.translations[i], b.translations[i]);
    EXPECT_NEAR(a.rotations[i].norm(), 1.0, 1e-12);
  }
  o.seed = 6;
  const Motion c = make_synthetic_walk(s, 100, 30, o);
  double difference = 0;
  for (size_t i = 0; i < a.rotations.size(); ++i) difference += (a.rotations[i].coeffs() - c.rotations[i].coeffs()).norm();
  EXPECT_GT(difference, 1.0);
  // Without noise the seed does not matter; non-root joints keep their rest offsets.
  o.noise_rad = 0;
  const Motion d = make_synthetic_walk(s, 10, 30, o);
  o.seed = 99;
  const Motion e = make_synthetic_walk(s, 10, 30, o);
  for (size_t i = 0; i < d.rotations.size(); ++i) EXPECT_EQ(d.rotations[i].coeffs(), e.rotations[i].coeffs());
  for (int j = 1; j < s.num_joints(); ++j) EXPECT_EQ(d.translation(5, j), s.offsets[j]);
  EXPECT_EQ(make_synthetic_walk(s, 0, 30).num_frames, 0);
  EXPECT_THROW(make_synthetic_walk(s, 10, 0), Error);
  EXPECT_THROW(make_synthetic_walk(s, -1, 30), Error);
}

TEST(Synthetic, RootMovesAtTheRequestedSpeedAlongTheHeading) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.speed_mps = 1.1;
  o.start_heading_rad = -0.8;
  const Motion m = make_synthetic_walk(s, 61, 30, o);
  const Eigen::Vector3d d = m.translation(60, 0) - m.translation(0, 0);
  EXPECT_NEAR(std::hypot(d.x(), d.z()), 220.0, 1e-9);  // 2 s at 110 cm/s
  EXPECT_NEAR(std::atan2(d.x(), d.z()), -0.8, 1e-12);
  // Turning: a circle of radius v / w; after a full turn the root is back where it started.
  o.turn_rate_rad_s = 2 * 3.14159265358979323846 / 4.0;
  const Motion c = make_synthetic_walk(s, 121, 30, o);
  const Eigen::Vector3d loop = c.translation(120, 0) - c.translation(0, 0);
  EXPECT_NEAR(std::hypot(loop.x(), loop.z()), 0.0, 1e-9);
  const Eigen::Vector3d half = c.translation(60, 0) - c.translation(0, 0);
  EXPECT_NEAR(std::hypot(half.x(), half.z()), 2 * 110.0 / o.turn_rate_rad_s, 1e-9);  // the diameter
}

TEST(Synthetic, FeetSwingInAntiphaseAndStayNearTheFloor) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.start_heading_rad = 0;  // walking along +Z
  const int frames = 90;
  const Motion m = make_synthetic_walk(s, frames, 30, o);
  const WorldPoses w = forward_kinematics(s, m);
  const int foot_l = s.find("Foot_L"), foot_r = s.find("Foot_R");
  double min_l = 1e9, max_l = -1e9, correlation = 0, lowest = 1e9;
  for (int t = 0; t < frames; ++t) {
    // Foot ahead of the hips, along the walking direction.
    const double ahead_l = w.position(t, foot_l).z() - w.position(t, 0).z();
    const double ahead_r = w.position(t, foot_r).z() - w.position(t, 0).z();
    min_l = std::min(min_l, ahead_l);
    max_l = std::max(max_l, ahead_l);
    correlation += ahead_l * ahead_r;
    lowest = std::min({lowest, w.position(t, foot_l).y(), w.position(t, foot_r).y()});
  }
  EXPECT_GT(max_l - min_l, 40.0);  // cm of swing
  EXPECT_LT(correlation, 0.0);
  EXPECT_GT(lowest, -5.0);
  EXPECT_LT(lowest, 15.0);
  // Hands hang below the shoulders.
  EXPECT_LT(w.position(10, s.find("Hand_L")).y(), w.position(10, s.find("UpperArm_L")).y() - 30);
}

}  // namespace
}  // namespace mosyn
