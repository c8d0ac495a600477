#include "core/subset.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/rotation.h"
#include "core/synthetic.h"
#include "test_bvh_reader.h"

namespace mosyn {
namespace {

// World positions and rotations of the kept joints equal the original ones.
void expect_same_world(const Skeleton& full, const Motion& full_motion, const Clip& sub, const std::vector<int>& kept,
                       double tolerance) {
  const WorldPoses a = forward_kinematics(full, full_motion), b = forward_kinematics(sub.skeleton, sub.motion);
  ASSERT_EQ(b.num_joints, static_cast<int>(kept.size()));
  for (int t = 0; t < full_motion.num_frames; ++t)
    for (size_t k = 0; k < kept.size(); ++k) {
      EXPECT_LT((b.position(t, static_cast<int>(k)) - a.position(t, kept[k])).norm(), tolerance)
          << full.joint_names[kept[k]] << " frame " << t;
      EXPECT_LT(geodesic_angle(b.rotation(t, static_cast<int>(k)), a.rotation(t, kept[k])), 1e-9);
    }
}

TEST(Subset, GlobMatch) {
  EXPECT_TRUE(glob_match("*", ""));
  EXPECT_TRUE(glob_match("*", "anything"));
  EXPECT_TRUE(glob_match("Left*", "LeftHandIndex1"));
  EXPECT_TRUE(glob_match("*Hand*", "LeftHandIndex1"));
  EXPECT_TRUE(glob_match("*Index?", "LeftHandIndex1"));
  EXPECT_TRUE(glob_match("a*b*c", "aXXbYYc"));
  EXPECT_TRUE(glob_match("a*b*c", "abc"));
  EXPECT_TRUE(glob_match("Hips", "Hips"));
  EXPECT_FALSE(glob_match("Hips", "hips"));
  EXPECT_FALSE(glob_match("Hip", "Hips"));
  EXPECT_FALSE(glob_match("a*b*c", "aXXbYY"));
  EXPECT_FALSE(glob_match("?", ""));
  EXPECT_FALSE(glob_match("*Index", "LeftHandIndex1"));
}

TEST(Subset, IndicesAndPatterns) {
  const Skeleton s = make_synthetic_biped();
  EXPECT_EQ(joint_indices(s, {"Head", "Hips"}), (std::vector<int>{4, 0}));
  try {
    joint_indices(s, {"Hips", "Tail"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Tail"), std::string::npos);
  }
  EXPECT_EQ(joints_matching(s, {"*_L"}), (std::vector<int>{5, 6, 7, 8, 13, 14, 15, 16}));
  EXPECT_EQ(joints_matching(s, {"Hand*", "Head"}), (std::vector<int>{4, 8, 12}));
  const std::vector<int> no_arms = joints_excluding(s, {"*Arm*", "Hand*"});
  EXPECT_EQ(no_arms.size(), static_cast<size_t>(s.num_joints() - 6));
  EXPECT_TRUE(joints_matching(s, finger_joint_patterns()).empty());
}

TEST(Subset, DroppingMiddleJointsKeepsWorldTransforms) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.5;
  o.noise_rad = 0.2;  // rotations on every joint, dropped ones included
  o.seed = 2;
  const Motion m = make_synthetic_walk(s, 40, 30, o);
  Motion animated = m;  // animated translations on dropped joints must be composed too
  for (int t = 0; t < m.num_frames; ++t) animated.translation(t, s.find("Spine")) += Eigen::Vector3d(1.0 * t, 2, -3);
  const std::vector<int> drop = joint_indices(s, {"Spine", "Chest", "LowerArm_L", "Foot_R", "Hand_R"});
  std::vector<int> keep;
  for (int j = 0; j < s.num_joints(); ++j)
    if (std::find(drop.begin(), drop.end(), j) == drop.end()) keep.push_back(j);
  std::vector<int> shuffled(keep.rbegin(), keep.rend());
  shuffled.push_back(keep[3]);  // order and duplicates do not matter

  for (const Motion* motion : {&m, static_cast<const Motion*>(&animated)}) {
    const Clip sub = subset_clip({s, *motion}, shuffled);
    EXPECT_NO_THROW(sub.skeleton.validate());
    EXPECT_NO_THROW(sub.motion.validate());
    ASSERT_EQ(sub.skeleton.num_joints(), s.num_joints() - 5);
    expect_same_world(s, *motion, sub, keep, 1e-9);
  }
  const Skeleton sub = subset_skeleton(s, keep);
  // Neck now hangs from Hips with the summed offsets; Hand_L from UpperArm_L.
  const int neck = sub.find("Neck");
  EXPECT_EQ(sub.parents[neck], 0);
  EXPECT_EQ(sub.offsets[neck], Eigen::Vector3d(0, 45, 0));
  EXPECT_EQ(sub.parents[sub.find("Hand_L")], sub.find("UpperArm_L"));
  EXPECT_EQ(sub.offsets[sub.find("Hand_L")], Eigen::Vector3d(53, 0, 0));
  EXPECT_EQ(sub.meters_per_unit, s.meters_per_unit);
  // Rest pose is unchanged too.
  expect_same_world(s, Motion::rest(s, 1, 30), {sub, Motion::rest(sub, 1, 30)}, keep, 1e-12);
}

TEST(Subset, EndSitesOfKeptJointsStayOthersGo) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 10, 30);
  const std::vector<int> keep = joints_excluding(s, {"Hand_R", "Toes_L"});
  const Clip sub = subset_clip({s, m}, keep);
  ASSERT_EQ(sub.skeleton.end_sites.size(), 3u);  // head top, Hand_L, Toes_R
  EXPECT_EQ(sub.skeleton.joint_names[sub.skeleton.end_sites[0].parent], "Head");
  EXPECT_EQ(sub.skeleton.joint_names[sub.skeleton.end_sites[1].parent], "Hand_L");
  EXPECT_EQ(sub.skeleton.joint_names[sub.skeleton.end_sites[2].parent], "Toes_R");
  const auto a = end_site_positions(s, forward_kinematics(s, m));
  const auto b = end_site_positions(sub.skeleton, forward_kinematics(sub.skeleton, sub.motion));
  const int original[] = {0, 1, 4};
  for (int t = 0; t < m.num_frames; ++t)
    for (int e = 0; e < 3; ++e) EXPECT_LT((b[t * 3 + e] - a[t * 5 + original[e]]).norm(), 1e-9);
}

TEST(Subset, RootMustBeKept) {
  const Skeleton s = make_synthetic_biped();
  try {
    subset_skeleton(s, {1, 2, 3});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Hips"), std::string::npos) << e.what();
  }
  EXPECT_THROW(subset_skeleton(s, {0, 99}), Error);
  EXPECT_THROW(subset_motion(s, make_synthetic_walk(s, 2, 30), {}), Error);
  // Keeping everything is the identity.
  std::vector<int> all(s.num_joints());
  for (int j = 0; j < s.num_joints(); ++j) all[j] = j;
  const Motion m = make_synthetic_walk(s, 5, 30);
  const Motion same = subset_motion(s, m, all);
  for (size_t i = 0; i < m.rotations.size(); ++i) {
    EXPECT_EQ(same.rotations[i].coeffs(), m.rotations[i].coeffs());
    EXPECT_EQ(same.translations[i], m.translations[i]);
  }
}

TEST(Subset, RealDataCmuWithoutFingers) {
  const std::string path = testing::data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  if (path.empty()) GTEST_SKIP() << "CMU data not unpacked";
  Clip clip = testing::read_bvh_for_tests(path);
  clip.motion.num_frames = 50;  // enough to check
  clip.motion.rotations.resize(50 * clip.motion.num_joints);
  clip.motion.translations.resize(50 * clip.motion.num_joints);
  const std::vector<int> keep = joints_excluding(clip.skeleton, finger_joint_patterns());
  const std::vector<int> fingers = joints_matching(clip.skeleton, finger_joint_patterns());
  ASSERT_EQ(fingers.size(), 6u);  // (Left|Right)FingerBase, (Left|Right)HandIndex1, LThumb, RThumb
  const Clip sub = subset_clip(clip, keep);
  EXPECT_EQ(sub.skeleton.num_joints(), 25);
  expect_same_world(clip.skeleton, clip.motion, sub, keep, 1e-9);
}

}  // namespace
}  // namespace mosyn
