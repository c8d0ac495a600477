#include "core/markers.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/rotation.h"
#include "test_bvh_reader.h"

namespace mosyn {
namespace {

// A Bandai-Namco-named skeleton in centimetres whose rest pose IS the canonical T-pose (spine up,
// arms along +-X, legs down, feet along (0, -0.3, 1)), so canonical_pose is the identity and every
// marker sits exactly at its anatomical definition: positions can be computed by hand.
Skeleton tpose_skeleton() {
  Skeleton s;
  s.meters_per_unit = 0.01;
  auto add = [&](const std::string& name, int parent, Eigen::Vector3d offset) {
    s.joint_names.push_back(name);
    s.parents.push_back(parent);
    s.offsets.push_back(offset);
    return static_cast<int>(s.joint_names.size()) - 1;
  };
  const int hips = add("Hips", -1, {0, 100, 0});
  const int spine = add("Spine", hips, {0, 10, 0});
  const int chest = add("Chest", spine, {0, 15, 0});
  const int neck = add("Neck", chest, {0, 20, 0});
  const int head = add("Head", neck, {0, 8, 0});
  s.end_sites.push_back({head, {0, 10, 0}});
  for (int side = 0; side < 2; ++side) {
    const double x = side == 0 ? 1.0 : -1.0;
    const std::string tag = side == 0 ? "_L" : "_R";
    const int sh = add("Shoulder" + tag, chest, {5 * x, 18, 0});
    const int ua = add("UpperArm" + tag, sh, {10 * x, 0, 0});
    const int la = add("LowerArm" + tag, ua, {28 * x, 0, 0});
    const int hand = add("Hand" + tag, la, {25 * x, 0, 0});
    s.end_sites.push_back({hand, {8 * x, 0, 0}});
  }
  for (int side = 0; side < 2; ++side) {
    const double x = side == 0 ? 1.0 : -1.0;
    const std::string tag = side == 0 ? "_L" : "_R";
    const int ul = add("UpperLeg" + tag, hips, {10 * x, -5, 0});
    const int ll = add("LowerLeg" + tag, ul, {0, -45, 0});
    const int foot = add("Foot" + tag, ll, {0, -42, 0});
    const int toe = add("Toes" + tag, foot, {0, -3.6, 12});
    s.end_sites.push_back({toe, {0, 0, 5}});
  }
  s.validate();
  return s;
}

Eigen::Vector3d marker_at(const Skeleton& s, const MarkerSet& set, const Motion& m, const std::string& name) {
  const auto all = marker_positions(s, set, m);
  const int i = set.find(name);
  EXPECT_GE(i, 0) << name;
  return all[i];
}

TEST(Markers, Cmu41LayoutHas41NamedMarkers) {
  const auto& names = cmu41_marker_names();
  EXPECT_EQ(names.size(), 41u);
  const MarkerSet set = cmu41_markers(tpose_skeleton());
  ASSERT_EQ(set.num_markers(), 41);
  for (int i = 0; i < 41; ++i) EXPECT_EQ(set.markers[i].name, names[i]);
}

TEST(Markers, CanonicalPoseOfATPoseSkeletonIsTheRestPose) {
  const Skeleton s = tpose_skeleton();
  const Motion canon = canonical_pose(s, find_body_parts(s));
  for (int j = 0; j < s.num_joints(); ++j)
    EXPECT_LT(geodesic_angle(canon.rotation(0, j), Eigen::Quaterniond::Identity()), 1e-9) << s.joint_names[j];
}

TEST(Markers, RestPositionsMatchHandComputedOnes) {
  const Skeleton s = tpose_skeleton();
  const MarkerSet set = cmu41_markers(s);
  const Motion rest = Motion::rest(s, 1, 30);
  // Head joint at (0, 153, 0) cm; LFHD 5 cm left, 11 up, 9 forward.
  EXPECT_LT((marker_at(s, set, rest, "LFHD") - Eigen::Vector3d(5, 164, 9)).norm(), 1e-9);
  EXPECT_LT((marker_at(s, set, rest, "RFHD") - Eigen::Vector3d(-5, 164, 9)).norm(), 1e-9);
  // Left elbow (forearm joint) at (43, 143, 0): LELB 2 cm up, 4.5 cm back.
  EXPECT_LT((marker_at(s, set, rest, "LELB") - Eigen::Vector3d(43, 145, -4.5)).norm(), 1e-9);
  // Left heel: ankle at (10, 8, 0), 4 cm below and 6 cm behind.
  EXPECT_LT((marker_at(s, set, rest, "LHEE") - Eigen::Vector3d(10, 4, -6)).norm(), 1e-9);
  // Left thigh marker: half-way hip (10, 95, 0) to knee (10, 50, 0), 7 cm out, 1 cm forward.
  EXPECT_LT((marker_at(s, set, rest, "LTHI") - Eigen::Vector3d(17, 72.5, 1)).norm(), 1e-9);
  // Neck base (0, 145, 0): C7 7 cm behind, STRN 20 cm down 10 cm forward.
  EXPECT_LT((marker_at(s, set, rest, "C7") - Eigen::Vector3d(0, 145, -7)).norm(), 1e-9);
  EXPECT_LT((marker_at(s, set, rest, "STRN") - Eigen::Vector3d(0, 125, 10)).norm(), 1e-9);
  // Markers ride their bone: LELB is carried by the upper arm, LIWR by the forearm.
  EXPECT_EQ(s.joint_names[set.markers[set.find("LELB")].joint], "UpperArm_L");
  EXPECT_EQ(s.joint_names[set.markers[set.find("LIWR")].joint], "LowerArm_L");
}

TEST(Markers, FollowTheirBoneRigidlyIncludingTwist) {
  const Skeleton s = tpose_skeleton();
  const MarkerSet set = cmu41_markers(s);
  Motion m = Motion::rest(s, 1, 30);
  // Twist the left upper arm 90 degrees about its own axis (+X): LELB at (28, 2, -4.5) from the
  // shoulder joint (15, 143, 0) goes to (28, 4.5, 2).
  m.rotation(0, s.find("UpperArm_L")) = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()));
  EXPECT_LT((marker_at(s, set, m, "LELB") - Eigen::Vector3d(43, 147.5, 2)).norm(), 1e-9);
  // A marker on the bone axis would not have moved; LELB did, by the twist alone.
  const Motion rest = Motion::rest(s, 1, 30);
  EXPECT_GT((marker_at(s, set, m, "LELB") - marker_at(s, set, rest, "LELB")).norm(), 5.0);
}

TEST(Markers, MissingBodyPartIsAnError) {
  Skeleton s = tpose_skeleton();
  s.joint_names[s.find("Head")] = "Skull";
  EXPECT_THROW(cmu41_markers(s), Error);
}

// A random pose: every joint rotated by up to `angle` radians, the root moved.
Motion random_pose(const Skeleton& s, double angle, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Motion m = Motion::rest(s, 1, 30);
  for (int j = 0; j < s.num_joints(); ++j) {
    const Eigen::Vector3d axis(u(rng), u(rng), u(rng));
    m.rotation(0, j) = quat_from_expmap(axis.normalized() * angle * std::abs(u(rng)));
  }
  m.translation(0, 0) += Eigen::Vector3d(30 * u(rng), 5 * u(rng), 30 * u(rng));
  return m;
}

// The fit recovers a pose from its own markers: every marker and joint position exactly, and the
// world rotation of every bone the markers pin down (three or more non-collinear points on it).
TEST(Markers, FitRecoversKnownRotationsFromTheirOwnMarkers) {
  const Skeleton s = tpose_skeleton();
  const MarkerSet set = cmu41_markers(s);
  const char* pinned[] = {"Hips", "Chest", "Head", "UpperArm_L", "LowerArm_L", "UpperArm_R", "LowerArm_R",
                          "UpperLeg_L", "LowerLeg_L", "Foot_L", "UpperLeg_R", "LowerLeg_R", "Foot_R"};
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Motion truth = random_pose(s, 0.8, seed);
    const auto targets = marker_positions(s, set, truth);
    // Warm start: the truth disturbed by up to 0.3 rad per joint (the previous frame of a motion).
    Motion fit = truth;
    const Motion noise = random_pose(s, 0.3, seed + 100);
    for (int j = 0; j < s.num_joints(); ++j) fit.rotation(0, j) = (noise.rotation(0, j) * truth.rotation(0, j)).normalized();
    fit.translation(0, 0) += Eigen::Vector3d(3, -2, 4);
    MarkerFitOptions options;
    options.pose_prior = 0.0;
    options.max_iterations = 100;
    const MarkerFitResult r = fit_markers(s, set, targets, &fit, 0, options);
    EXPECT_LT(r.rms_error, 1e-6) << "seed " << seed;
    const WorldPoses a = forward_kinematics(s, truth), b = forward_kinematics(s, fit);
    for (int j = 0; j < s.num_joints(); ++j)
      EXPECT_LT((a.position(0, j) - b.position(0, j)).norm(), 1e-5) << s.joint_names[j] << " seed " << seed;
    for (const char* name : pinned) {
      const int j = s.find(name);
      EXPECT_LT(geodesic_angle(a.rotation(0, j), b.rotation(0, j)), 1e-6) << name << " seed " << seed;
    }
  }
}

TEST(Markers, FitFromTheCanonicalStartReachesAModeratePose) {
  const Skeleton s = tpose_skeleton();
  const MarkerSet set = cmu41_markers(s);
  Motion truth = random_pose(s, 0.5, 7);
  truth.rotation(0, 0) = (quat_about_axis(1, 2.0) * truth.rotation(0, 0)).normalized();  // facing elsewhere
  const auto targets = marker_positions(s, set, truth);
  Motion fit = Motion::rest(s, 1, 30);
  initialise_from_markers(s, set, targets, &fit, 0);
  MarkerFitOptions options;
  options.max_iterations = 200;
  options.pose_prior = 0.0;
  const MarkerFitResult r = fit_markers(s, set, targets, &fit, 0, options);
  EXPECT_LT(r.rms_error, 1e-4);
}

TEST(Markers, PosePriorKeepsUnseenTwistWhereItWas) {
  // The neck carries no marker and the hand's twist about its bone moves only LFIN along its
  // axis: with the prior, a fit from the truth stays at the truth (nothing pulls it away).
  const Skeleton s = tpose_skeleton();
  const MarkerSet set = cmu41_markers(s);
  const Motion truth = random_pose(s, 0.6, 3);
  Motion fit = truth;
  const MarkerFitResult r = fit_markers(s, set, marker_positions(s, set, truth), &fit, 0);
  EXPECT_LT(r.rms_error, 1e-9);
  for (int j = 0; j < s.num_joints(); ++j) EXPECT_LT(geodesic_angle(truth.rotation(0, j), fit.rotation(0, j)), 1e-9);
}


// Real skeletons: the layout is anatomical on real motion (head markers above the shoulders above
// the waist above the knees above the heels, left markers on the body's left), every marker stays
// within 25 cm of its joint, and a frame-by-frame fit warm-started from the previous frame gives
// the markers back.
void check_real_clip(Clip clip, int frames) {
  const Skeleton& s = clip.skeleton;
  const MarkerSet set = cmu41_markers(s);
  clip.motion.num_frames = std::min(frames, clip.motion.num_frames);
  clip.motion.rotations.resize(static_cast<size_t>(clip.motion.num_frames) * clip.motion.num_joints);
  clip.motion.translations.resize(static_cast<size_t>(clip.motion.num_frames) * clip.motion.num_joints);
  const auto all = marker_positions(s, set, clip.motion);
  const WorldPoses world = forward_kinematics(s, clip.motion);
  const int m = set.num_markers(), up = s.up_axis;
  auto h = [&](int t, const char* name) { return all[static_cast<size_t>(t) * m + set.find(name)][up]; };
  for (int t = 0; t < clip.motion.num_frames; ++t) {
    EXPECT_GT(h(t, "LFHD"), h(t, "LSHO"));
    EXPECT_GT(h(t, "RBHD"), h(t, "RSHO"));
    EXPECT_GT(h(t, "CLAV"), h(t, "STRN"));
    EXPECT_GT(h(t, "LFWT"), h(t, "LKNE"));
    EXPECT_GT(h(t, "RKNE"), h(t, "RHEE"));
    const Eigen::Vector3d left = all[static_cast<size_t>(t) * m + set.find("LFWT")] - all[static_cast<size_t>(t) * m + set.find("RFWT")];
    const Eigen::Vector3d hips_left = world.position(t, s.find(s.find("UpperLeg_L") >= 0 ? "UpperLeg_L" : "LeftUpLeg")) -
                                      world.position(t, s.find(s.find("UpperLeg_R") >= 0 ? "UpperLeg_R" : "RightUpLeg"));
    EXPECT_GT(left.dot(hips_left), 0.0);
    for (int i = 0; i < m; ++i) {
      // Distance to the nearest bone segment (parent to child joint).
      const Eigen::Vector3d x = all[static_cast<size_t>(t) * m + i];
      double nearest = 1e30;
      for (int j = 1; j < s.num_joints(); ++j) {
        const Eigen::Vector3d a = world.position(t, s.parents[j]), b = world.position(t, j);
        const double len2 = (b - a).squaredNorm();
        const double u = len2 > 0 ? std::clamp((x - a).dot(b - a) / len2, 0.0, 1.0) : 0.0;
        nearest = std::min(nearest, (a + u * (b - a) - x).norm());
      }
      EXPECT_LT(nearest * s.meters_per_unit, 0.18) << set.markers[i].name;  // head markers: 15 cm from the skull-base joint
    }
  }
  // CMU clips open with a T-pose frame: warm starts begin from frame 1.
  Motion fit = clip.motion;
  for (int t = 2; t < clip.motion.num_frames; ++t) {
    for (int j = 0; j < s.num_joints(); ++j) {
      fit.rotation(t, j) = fit.rotation(t - 1, j);
      if (j == 0) fit.translation(t, j) = fit.translation(t - 1, j);
    }
    const std::vector<Eigen::Vector3d> targets(all.begin() + static_cast<long>(t) * m, all.begin() + static_cast<long>(t + 1) * m);
    const MarkerFitResult r = fit_markers(s, set, targets, &fit, t);
    EXPECT_LT(r.rms_error * s.meters_per_unit, 1e-3) << "frame " << t << " after " << r.iterations << " iterations";
  }
}

TEST(Markers, RealDataBandaiNamco) {
  const std::string path =
      testing::data_file("bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_raise-up-both-hands_active_001.bvh");
  if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
  check_real_clip(testing::read_bvh_for_tests(path), 60);
}

TEST(Markers, RealDataCmu) {
  const std::string path = testing::data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  if (path.empty()) GTEST_SKIP() << "CMU data not unpacked";
  Clip clip = testing::read_bvh_for_tests(path);
  clip.skeleton.meters_per_unit = 0.0254 / 0.45;  // CMU's units: 1/0.45 inch
  check_real_clip(clip, 60);
}

}  // namespace
}  // namespace mosyn
