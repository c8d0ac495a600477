#include "core/foot_lock.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"

namespace mosyn {
namespace {

TEST(FootLock, FindsBothLegsOfTheBiped) {
  const Skeleton s = make_synthetic_biped();
  const std::vector<LegChain> legs = find_legs(s);
  ASSERT_EQ(legs.size(), 2u);
  EXPECT_EQ(s.joint_names[legs[0].ankle], "Foot_L");
  EXPECT_EQ(s.joint_names[legs[0].knee], "LowerLeg_L");
  EXPECT_EQ(s.joint_names[legs[0].hip], "UpperLeg_L");
}

TEST(FootLock, TwoBoneKneeKeepsBoneLengthsAndBendPlane) {
  const Eigen::Vector3d hip(0, 1, 0), knee(0.05, 0.55, 0.1), target(0.1, 0.15, 0.2);
  const Eigen::Vector3d k = two_bone_knee(hip, knee, target, 0.45, 0.43);
  EXPECT_NEAR((k - hip).norm(), 0.45, 1e-9);
  EXPECT_NEAR((target - k).norm(), 0.43, 1e-9);
  // The new knee lies in the plane of hip, target and old knee, on the old knee's side.
  const Eigen::Vector3d normal = (target - hip).cross(knee - hip).normalized();
  EXPECT_NEAR((k - hip).dot(normal), 0.0, 1e-9);
  const Eigen::Vector3d axis = (target - hip).normalized();
  EXPECT_GT(((k - hip) - (k - hip).dot(axis) * axis).dot((knee - hip) - (knee - hip).dot(axis) * axis), 0.0);
  // Out of reach: the leg straightens towards the target.
  const Eigen::Vector3d far(0, -2, 0);
  const Eigen::Vector3d straight = two_bone_knee(hip, knee, far, 0.45, 0.43);
  EXPECT_NEAR((straight - hip).norm(), 0.45, 1e-9);
  EXPECT_LT(((straight - hip).normalized() - (far - hip).normalized()).norm(), 1e-3);
}

// A crouched stance whose hips drift 8 cm while both feet should stay planted: after the lock
// the ankles stay at one floor position, their heights and every non-leg joint are unchanged.
TEST(FootLock, PinsSlidingFeetAndTouchesOnlyTheLegs) {
  const Skeleton s = make_synthetic_biped();
  const int frames = 31;
  Motion m = Motion::rest(s, frames, 30.0);
  const auto legs = find_legs(s);
  for (int t = 0; t < frames; ++t) {
    m.translation(t, 0) = Eigen::Vector3d(0, 90, 8.0 * t / (frames - 1));  // centimetres
    for (const LegChain& leg : legs) {
      m.rotation(t, leg.hip) = Eigen::Quaterniond(Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()));
      m.rotation(t, leg.knee) = Eigen::Quaterniond(Eigen::AngleAxisd(0.6, Eigen::Vector3d::UnitX()));
      m.rotation(t, leg.ankle) = Eigen::Quaterniond(Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitX()));
    }
  }
  FootLockReport report;
  const Motion locked = foot_lock(s, m, {}, &report);
  EXPECT_EQ(report.contacts, 2);
  EXPECT_GT(report.max_correction_m, 0.03);
  const WorldPoses before = forward_kinematics(s, m), after = forward_kinematics(s, locked);
  for (const LegChain& leg : legs) {
    for (int t = 0; t < frames; ++t) {
      const Eigen::Vector3d a = after.position(t, leg.ankle), a0 = after.position(0, leg.ankle);
      EXPECT_NEAR(a.x(), a0.x(), 1e-6);
      EXPECT_NEAR(a.z(), a0.z(), 1e-6);
      EXPECT_NEAR(a.y(), before.position(t, leg.ankle).y(), 1e-6);
      // The foot keeps its world orientation.
      EXPECT_TRUE(after.rotation(t, leg.ankle).isApprox(before.rotation(t, leg.ankle), 1e-9));
    }
  }
  for (int t = 0; t < frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      bool in_leg = false;
      for (const LegChain& leg : legs) in_leg = in_leg || j == leg.hip || j == leg.knee || j == leg.ankle;
      if (!in_leg) {
        EXPECT_TRUE(locked.rotation(t, j).isApprox(m.rotation(t, j))) << s.joint_names[j];
      }
    }
  EXPECT_THROW(foot_lock(s, m, FootLockOptions{0.0, 0.4, 0.08, 0.1}), Error);

  // Frame by frame: the first frame's ankle is pinned once the blend-in (3 frames) is done.
  StreamingFootLock stream(s, 30.0);
  for (int t = 0; t < frames; ++t) {
    Motion one = Motion::rest(s, 1, 30.0);
    for (int j = 0; j < s.num_joints(); ++j) {
      one.rotation(0, j) = m.rotation(t, j);
      one.translation(0, j) = m.translation(t, j);
    }
    const WorldPoses w = forward_kinematics(s, stream.apply(one));
    for (const LegChain& leg : legs) {
      if (t < 2) continue;
      EXPECT_NEAR(w.position(0, leg.ankle).x(), before.position(0, leg.ankle).x(), 1e-6) << t;
      EXPECT_NEAR(w.position(0, leg.ankle).z(), before.position(0, leg.ankle).z(), 1e-6) << t;
    }
  }
  EXPECT_THROW(stream.apply(m), Error);  // one frame at a time
}

}  // namespace
}  // namespace mosyn
