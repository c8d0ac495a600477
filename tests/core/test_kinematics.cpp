#include "core/kinematics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/rotation.h"
#include "core/synthetic.h"

namespace mosyn {
namespace {

constexpr double kPi = 3.14159265358979323846;

Skeleton chain3() {
  Skeleton s;
  s.joint_names = {"root", "a", "b"};
  s.parents = {-1, 0, 1};
  s.offsets = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  s.end_sites = {{2, {0, 0, 2}}, {0, {0, 0, 1}}};
  return s;
}

TEST(Kinematics, ThreeJointChainByHand) {
  const Skeleton s = chain3();
  Motion m = Motion::rest(s, 2, 30);
  m.translation(0, 0) = {1, 2, 3};
  m.rotation(0, 0) = quat_about_axis(2, kPi / 2);  // (x, y, z) -> (-y, x, z)
  m.rotation(0, 1) = quat_about_axis(0, kPi / 2);  // (x, y, z) -> (x, -z, y)
  const WorldPoses w = forward_kinematics(s, m);
  ASSERT_EQ(w.num_frames, 2);
  ASSERT_EQ(w.num_joints, 3);
  // Frame 0: p1 = (1,2,3) + Rz (1,0,0); p2 = p1 + Rz Rx (0,1,0).
  EXPECT_LT((w.position(0, 0) - Eigen::Vector3d(1, 2, 3)).norm(), 1e-15);
  EXPECT_LT((w.position(0, 1) - Eigen::Vector3d(1, 3, 3)).norm(), 1e-15);
  EXPECT_LT((w.position(0, 2) - Eigen::Vector3d(1, 3, 4)).norm(), 1e-15);
  const Eigen::Matrix3d r2 = w.rotation(0, 2).toRotationMatrix();
  Eigen::Matrix3d expected;  // columns: images of X, Y, Z under Rz(90) Rx(90)
  expected << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  EXPECT_LT((r2 - expected).norm(), 1e-15);
  // Frame 1 is the rest pose: offsets add up.
  EXPECT_LT((w.position(1, 2) - Eigen::Vector3d(1, 1, 0)).norm(), 1e-15);

  const std::vector<Eigen::Vector3d> ends = end_site_positions(s, w);
  ASSERT_EQ(ends.size(), 4u);  // [T, E]
  // Frame 0: p2 + Rz Rx (0,0,2) = (1,3,4) + (2,0,0); root's site: (1,2,3) + Rz (0,0,1).
  EXPECT_LT((ends[0] - Eigen::Vector3d(3, 3, 4)).norm(), 1e-15);
  EXPECT_LT((ends[1] - Eigen::Vector3d(1, 2, 4)).norm(), 1e-15);
  EXPECT_LT((ends[2] - Eigen::Vector3d(1, 1, 2)).norm(), 1e-15);
  EXPECT_LT((ends[3] - Eigen::Vector3d(0, 0, 1)).norm(), 1e-15);
}

TEST(Kinematics, AnimatedTranslationOfAChildIsUsed) {
  const Skeleton s = chain3();
  Motion m = Motion::rest(s, 1, 30);
  m.rotation(0, 0) = quat_about_axis(1, kPi);  // (x, y, z) -> (-x, y, -z)
  m.translation(0, 1) = {2, 0, 5};
  const WorldPoses w = forward_kinematics(s, m);
  EXPECT_LT((w.position(0, 1) - Eigen::Vector3d(-2, 0, -5)).norm(), 1e-14);
  EXPECT_LT((w.position(0, 2) - Eigen::Vector3d(-2, 1, -5)).norm(), 1e-14);
}

TEST(Kinematics, MatchesRecursiveMatrixComputationOnSyntheticWalk) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.noise_rad = 0.1;
  o.turn_rate_rad_s = 0.4;
  const Motion m = make_synthetic_walk(s, 20, 30, o);
  const WorldPoses w = forward_kinematics(s, m);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      // Brute force: 4x4 homogeneous product along the chain from the root.
      Eigen::Matrix4d world = Eigen::Matrix4d::Identity();
      std::vector<int> chain;
      for (int k = j; k >= 0; k = s.parents[k]) chain.insert(chain.begin(), k);
      for (int k : chain) {
        Eigen::Matrix4d local = Eigen::Matrix4d::Identity();
        local.topLeftCorner<3, 3>() = m.rotation(t, k).toRotationMatrix();
        local.topRightCorner<3, 1>() = m.translation(t, k);
        world = world * local;
      }
      EXPECT_LT((w.position(t, j) - world.topRightCorner<3, 1>()).norm(), 1e-10);
      EXPECT_LT((w.rotation(t, j).toRotationMatrix() - world.topLeftCorner<3, 3>()).norm(), 1e-12);
    }
}

TEST(Kinematics, RejectsMismatchedMotion) {
  const Skeleton s = chain3();
  Motion m = Motion::rest(s, 2, 30);
  m.num_joints = 2;
  EXPECT_THROW(forward_kinematics(s, m), Error);
  Motion short_arrays = Motion::rest(s, 2, 30);
  short_arrays.rotations.pop_back();
  EXPECT_THROW(forward_kinematics(s, short_arrays), Error);
}

}  // namespace
}  // namespace mosyn
