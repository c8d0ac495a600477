#include "core/mirror.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "test_bvh_reader.h"

namespace mosyn {
namespace {

Skeleton named(const std::vector<std::string>& names) {
  Skeleton s;
  s.joint_names = names;
  for (size_t j = 0; j < names.size(); ++j) {
    s.parents.push_back(j == 0 ? -1 : 0);
    s.offsets.emplace_back(static_cast<double>(j), 1, 0);
  }
  return s;
}

SyntheticWalkOptions noisy_turning_walk() {
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.7;
  o.noise_rad = 0.05;
  o.seed = 17;
  return o;
}

TEST(Mirror, MapFromNameConventions) {
  const Skeleton s = named({"Hips", "LeftArm", "RightArm", "LHipJoint", "RHipJoint", "Hand_L", "Hand_R",
                            "left_foot", "right_foot", "Hand.L", "Hand.R", "l_eye", "r_eye", "Bip01 L Thigh",
                            "Bip01 R Thigh", "HandLeft", "HandRight", "LowerBack", "Root_L", "Spine"});
  const std::vector<int> map = mirror_map(s);
  const std::vector<int> expected = {0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15, 17, 18, 19};
  EXPECT_EQ(map, expected);
  const std::vector<int> sides = joint_sides(s);
  const std::vector<int> expected_sides = {0, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0};
  EXPECT_EQ(sides, expected_sides);
}

TEST(Mirror, MapOfSyntheticBiped) {
  const Skeleton s = make_synthetic_biped();
  const std::vector<int> map = mirror_map(s);
  for (int j = 0; j < s.num_joints(); ++j) {
    EXPECT_EQ(map[map[j]], j);
    const std::string& name = s.joint_names[j];
    if (name.size() > 2 && name.compare(name.size() - 2, 2, "_L") == 0)
      EXPECT_EQ(s.joint_names[map[j]], name.substr(0, name.size() - 2) + "_R");
    else if (name.size() > 2 && name.compare(name.size() - 2, 2, "_R") == 0)
      EXPECT_EQ(s.joint_names[map[j]], name.substr(0, name.size() - 2) + "_L");
    else
      EXPECT_EQ(map[j], j) << name;
  }
  EXPECT_EQ(default_mirror_axis(s), 0);
  EXPECT_EQ(mirror_asymmetry(s, map, 0), 0.0);
  EXPECT_GT(mirror_asymmetry(s, map, 2), 1.0);  // arms point along X: not symmetric about Z
  Skeleton bent = s;
  bent.offsets[s.find("LowerArm_L")].y() += 0.5;
  EXPECT_NEAR(mirror_asymmetry(bent, map, 0), 0.5, 1e-12);
}

TEST(Mirror, QuaternionReflectionFormula) {
  Skeleton s;
  s.joint_names = {"root"};
  s.parents = {-1};
  s.offsets = {{0, 0, 0}};
  Motion m = Motion::rest(s, 1, 30);
  m.rotation(0, 0) = Eigen::Quaterniond(0.5, 0.1, -0.7, 0.3).normalized();
  m.translation(0, 0) = {1, 2, 3};
  const Eigen::Quaterniond q = m.rotation(0, 0);
  const Motion x = mirror_motion(s, m, {0}, 0), y = mirror_motion(s, m, {0}, 1), z = mirror_motion(s, m, {0}, 2);
  EXPECT_EQ(x.rotation(0, 0).coeffs(), Eigen::Quaterniond(q.w(), q.x(), -q.y(), -q.z()).coeffs());
  EXPECT_EQ(y.rotation(0, 0).coeffs(), Eigen::Quaterniond(q.w(), -q.x(), q.y(), -q.z()).coeffs());
  EXPECT_EQ(z.rotation(0, 0).coeffs(), Eigen::Quaterniond(q.w(), -q.x(), -q.y(), q.z()).coeffs());
  EXPECT_EQ(x.translation(0, 0), Eigen::Vector3d(-1, 2, 3));
  // And it is S R S as matrices.
  for (int axis = 0; axis < 3; ++axis) {
    Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
    S(axis, axis) = -1;
    const Motion r = mirror_motion(s, m, {0}, axis);
    EXPECT_LT((r.rotation(0, 0).toRotationMatrix() - S * q.toRotationMatrix() * S).norm(), 1e-14);
  }
}

TEST(Mirror, TwiceIsIdentity) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 60, 30, noisy_turning_walk());
  const std::vector<int> map = mirror_map(s);
  for (int axis = 0; axis < 3; ++axis) {
    const Motion twice = mirror_motion(s, mirror_motion(s, m, map, axis), map, axis);
    ASSERT_EQ(twice.num_frames, m.num_frames);
    for (size_t i = 0; i < m.rotations.size(); ++i) {
      EXPECT_EQ(twice.rotations[i].coeffs(), m.rotations[i].coeffs());
      EXPECT_LT((twice.translations[i] - m.translations[i]).norm(), 1e-12);
    }
  }
}

TEST(Mirror, WorldPositionsReflectOnSymmetricSkeleton) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 60, 30, noisy_turning_walk());
  const std::vector<int> map = mirror_map(s);
  const Motion mirrored = mirror_motion(s, m, map, 0);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(s, mirrored);
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 0) = -1;
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      EXPECT_LT((b.position(t, j) - S * a.position(t, map[j])).norm(), 1e-9);
      EXPECT_LT((b.rotation(t, j).toRotationMatrix() - S * a.rotation(t, map[j]).toRotationMatrix() * S).norm(),
                1e-12);
    }
  // End sites too: head top stays, hands and toes swap.
  const auto ea = end_site_positions(s, a), eb = end_site_positions(s, b);
  const int sites = static_cast<int>(s.end_sites.size());
  const int site_map[] = {0, 2, 1, 4, 3};
  for (int t = 0; t < m.num_frames; ++t)
    for (int e = 0; e < sites; ++e) EXPECT_LT((eb[t * sites + e] - S * ea[t * sites + site_map[e]]).norm(), 1e-9);
}

TEST(Mirror, MirroredWalkTurnsTheOtherWay) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 120, 30, noisy_turning_walk());
  const Motion r = mirror_motion(s, m, mirror_map(s), default_mirror_axis(s));
  const Eigen::Vector3d f = estimate_forward_in_root(s);
  const GroundTrajectory a = ground_trajectory(s, m, 0, f), b = ground_trajectory(s, r, 0, f);
  for (int t = 0; t < m.num_frames; ++t) EXPECT_NEAR(b.headings_rad[t], -a.headings_rad[t], 1e-9);
  const auto da = root_deltas(s, a), db = root_deltas(s, b);
  for (int t = 0; t < m.num_frames; ++t) {
    EXPECT_NEAR(db[t].forward, da[t].forward, 1e-9);
    EXPECT_NEAR(db[t].sideways, -da[t].sideways, 1e-9);
    EXPECT_NEAR(db[t].turn_rad, -da[t].turn_rad, 1e-9);
  }
}

TEST(Mirror, RejectsBadArguments) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 3, 30);
  std::vector<int> map = mirror_map(s);
  EXPECT_THROW(mirror_motion(s, m, map, 3), Error);
  map[5] = 0;  // not an involution
  EXPECT_THROW(mirror_motion(s, m, map, 0), Error);
  EXPECT_THROW(mirror_motion(s, m, std::vector<int>(3, 0), 0), Error);
}

TEST(Mirror, RealDataCmuAndBandaiPairs) {
  const std::string cmu = testing::data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  const std::string bandai = testing::data_file(
      "bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk_normal_001.bvh");
  if (cmu.empty() || bandai.empty()) GTEST_SKIP() << "data not unpacked";
  const Skeleton c = testing::read_bvh_for_tests(cmu).skeleton;
  const std::vector<int> cmap = mirror_map(c);
  int unpaired = 0;
  for (int j = 0; j < c.num_joints(); ++j) unpaired += cmap[j] == j;
  EXPECT_EQ(unpaired, 7);  // Hips, LowerBack, Spine, Spine1, Neck, Neck1, Head
  EXPECT_EQ(cmap[c.find("LThumb")], c.find("RThumb"));
  EXPECT_EQ(cmap[c.find("LHipJoint")], c.find("RHipJoint"));
  EXPECT_EQ(cmap[c.find("LeftHandIndex1")], c.find("RightHandIndex1"));
  EXPECT_EQ(joint_sides(c)[c.find("LeftUpLeg")], 1);
  const Skeleton b = testing::read_bvh_for_tests(bandai).skeleton;
  const std::vector<int> bmap = mirror_map(b);
  unpaired = 0;
  for (int j = 0; j < b.num_joints(); ++j) unpaired += bmap[j] == j;
  EXPECT_EQ(unpaired, 6);  // joint_Root, Hips, Spine, Chest, Neck, Head
  EXPECT_EQ(bmap[b.find("Toes_L")], b.find("Toes_R"));
  // Bandai-Namco's rest pose is not symmetric about one plane (see mirror_motion).
  EXPECT_GT(mirror_asymmetry(b, bmap, default_mirror_axis(b)), 10.0);
}

}  // namespace
}  // namespace mosyn
