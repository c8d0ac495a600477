#include "data/augment.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/mirror.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "core/units.h"
#include "data/labels.h"
#include "data/representation.h"
#include "io/bvh.h"

namespace mosyn::data {
namespace {

double max_motion_difference(const Motion& a, const Motion& b) {
  double worst = 0;
  for (size_t i = 0; i < a.rotations.size(); ++i) {
    worst = std::max(worst, a.rotations[i].angularDistance(b.rotations[i]));
    worst = std::max(worst, (a.translations[i] - b.translations[i]).norm());
  }
  return worst;
}

// World positions of the mirrored motion versus the reflected positions of the partners,
// relative to the skeleton's height.
double mirror_position_error(const Skeleton& s, const Motion& m, const MirrorPlan& plan) {
  const Motion mirrored = mirror(s, m, plan);
  const WorldPoses a = forward_kinematics(s, m), b = forward_kinematics(s, mirrored);
  double worst = 0;
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      Eigen::Vector3d expected = a.position(t, plan.map[j]);
      expected[plan.world_axis] = -expected[plan.world_axis];
      worst = std::max(worst, (b.position(t, j) - expected).norm());
    }
  return worst / estimate_height_units(s);
}

TEST(Augment, MirrorSyntheticIsExactAndInvolutive) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.7;
  o.noise_rad = 0.05;
  const Motion m = make_synthetic_walk(s, 50, 30.0, o);
  const MirrorPlan plan = plan_mirror(s);
  EXPECT_EQ(plan.world_axis, 0);
  EXPECT_NEAR(plan.asymmetry, 0.0, 1e-9);
  EXPECT_EQ(s.joint_names[plan.map[s.find("Hand_L")]], "Hand_R");
  EXPECT_LT(mirror_position_error(s, m, plan), 1e-9);
  EXPECT_LT(max_motion_difference(mirror(s, mirror(s, m, plan), plan), m), 1e-9);
  // Same result as core's mirror_motion on a symmetric skeleton.
  const Motion core = mirror_motion(s, m, plan.map, plan.world_axis);
  const WorldPoses a = forward_kinematics(s, core), b = forward_kinematics(s, mirror(s, m, plan));
  for (size_t i = 0; i < a.positions.size(); ++i) EXPECT_LT((a.positions[i] - b.positions[i]).norm(), 1e-9);
  // A left turn becomes a right turn.
  const Eigen::Vector3d fwd = estimate_forward_in_root(s);
  const GroundTrajectory g0 = ground_trajectory(s, m, 0, fwd), g1 = ground_trajectory(s, mirror(s, m, plan), 0, fwd);
  EXPECT_NEAR(g1.headings_rad.back() - g1.headings_rad.front(), -(g0.headings_rad.back() - g0.headings_rad.front()),
              1e-9);
}

TEST(Augment, ReverseTwiceIsIdentityAndDeltasAreConsistent) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.sway_rad = 0;
  const Motion m = make_synthetic_walk(s, 40, 30.0, o);
  const Motion r = reverse_frames(m);
  EXPECT_LT(max_motion_difference(reverse_frames(r), m), 1e-12);
  EXPECT_TRUE(r.rotation(0, 3).isApprox(m.rotation(39, 3)));
  // Played backwards the walker moves backwards: negative forward deltas.
  const FeatureLayout layout = make_layout(s, PoseForm::kRotations, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  encode(s, r, layout, &pose, &control);
  for (int t = 1; t < 40; ++t) EXPECT_LT(control[3 * t + 1], 0.0f);
}

// Played 1.5 times as fast: frame k is source frame 1.5 k (hand-interpolated between frames),
// a third fewer frames, the same frame rate, and the walker's ground speed times 1.5.
TEST(Augment, RetimePlaysFasterAtTheSameRate) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.speed_mps = 1.2;
  const Motion m = make_synthetic_walk(s, 61, 30.0, o);
  const Motion r = retime(m, 1.5);
  EXPECT_DOUBLE_EQ(r.fps, 30.0);
  EXPECT_EQ(r.num_frames, 41);  // frames 0, 1.5, ..., 60
  EXPECT_NO_THROW(r.validate());
  for (int k = 0; k < r.num_frames; k += 2)  // even k: exactly a source frame
    for (int j = 0; j < s.num_joints(); ++j) EXPECT_LT(r.rotation(k, j).angularDistance(m.rotation(3 * k / 2, j)), 1e-9);
  const Eigen::Vector3d mid = 0.5 * (m.translation(1, 0) + m.translation(2, 0));  // source time 1.5
  EXPECT_LT((r.translation(1, 0) - mid).norm(), 1e-9);
  const double source_speed = (m.translation(60, 0) - m.translation(0, 0)).norm() / 2.0;  // over 2 s
  const double retimed_speed = (r.translation(40, 0) - r.translation(0, 0)).norm() / (40 / 30.0);
  EXPECT_NEAR(retimed_speed / source_speed, 1.5, 1e-9);
  // Slower: 0.5 doubles the frames.
  EXPECT_EQ(retime(m, 0.5).num_frames, 121);
  EXPECT_THROW(retime(m, 0.0), Error);
  EXPECT_THROW(retime(m, std::nan("")), Error);
}

// double_support_frame against a brute-force search over the FK of the ankles; come_to_rest by
// hand: the source played as recorded, then the ramp's source times u0 + v - v^2 / (2 ramp), then
// the rest frame held; the start the same reversed in time.
TEST(Augment, ComeToRestRampsToTheDoubleSupportFrameAndHolds) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 91, 30.0);  // 3 s
  const WorldPoses world = forward_kinematics(s, m);
  const int ankles[2] = {s.find("Foot_L"), s.find("Foot_R")};
  const auto slower_at = [&](int t) {  // the larger ankle ground speed into frame t, units per frame
    double v = 0;
    for (int a : ankles) {
      Eigen::Vector3d d = world.position(t, a) - world.position(t - 1, a);
      d[s.up_axis] = 0;
      v = std::max(v, d.norm());
    }
    return v;
  };
  int best_end = 45;
  for (int t = 45; t <= 90; ++t) best_end = slower_at(t) < slower_at(best_end) ? t : best_end;
  const int rest = double_support_frame(s, m, RestEnd::kEnd);
  EXPECT_EQ(rest, best_end);
  const int start_rest = double_support_frame(s, m, RestEnd::kStart);
  EXPECT_GE(start_rest, 1);
  EXPECT_LE(start_rest, 45);
  const double ramp = 1.0, hold = 2.0, u0 = rest / 30.0 - ramp / 2;
  const Motion stop = come_to_rest(m, rest, RestEnd::kEnd, ramp, hold);
  EXPECT_NO_THROW(stop.validate());
  EXPECT_EQ(stop.num_frames, static_cast<int>(std::floor((u0 + ramp + hold) * 30 + 1e-9)) + 1);
  EXPECT_LT(max_motion_difference(slice_frames(stop, 0, 10), slice_frames(m, 0, 10)), 1e-9);  // as recorded
  const Motion rest_pose = slice_frames(m, rest, 1);
  const int ramp_end = static_cast<int>(std::ceil((u0 + ramp) * 30));
  for (int k = ramp_end; k < stop.num_frames; ++k)
    EXPECT_LT(max_motion_difference(slice_frames(stop, k, 1), rest_pose), 1e-9) << k;
  // Mid-ramp: source time u0 + 0.5 - 0.125, i.e. the source resampled there.
  const int mid = static_cast<int>(std::lround((u0 + 0.5) * 30));
  const double v = mid / 30.0 - u0, source_s = u0 + v - v * v / (2 * ramp);
  const double s_frames = source_s * 30;
  const int a = static_cast<int>(std::floor(s_frames));
  const Eigen::Vector3d expected =
      (1 - (s_frames - a)) * m.translation(a, 0) + (s_frames - a) * m.translation(a + 1, 0);
  EXPECT_LT((stop.translation(mid, 0) - expected).norm(), 1e-9);
  // The root slows: its ground step in the ramp's last frames is a fraction of the walk's.
  const auto ground_step = [&](const Motion& x, int k) {
    Eigen::Vector3d d = x.translation(k, 0) - x.translation(k - 1, 0);
    d[s.up_axis] = 0;
    return d.norm();
  };
  EXPECT_LT(ground_step(stop, ramp_end - 1), 0.15 * ground_step(stop, 5));
  // The start: the rest pose held first, then the walk on to the source's last frame.
  const Motion go = come_to_rest(m, start_rest, RestEnd::kStart, ramp, hold);
  EXPECT_LT(max_motion_difference(slice_frames(go, 0, 1), slice_frames(m, start_rest, 1)), 1e-9);
  EXPECT_LT(max_motion_difference(slice_frames(go, 59, 1), slice_frames(m, start_rest, 1)), 1e-9);
  EXPECT_LT(ground_step(go, 62), 0.15 * ground_step(go, go.num_frames - 1));
  EXPECT_LT((go.translation(go.num_frames - 1, 0) - m.translation(90, 0)).norm(), 1e-6);
  EXPECT_THROW(come_to_rest(m, rest, RestEnd::kEnd, -1.0, hold), Error);
  EXPECT_THROW(come_to_rest(m, 91, RestEnd::kEnd, ramp, hold), Error);
  EXPECT_THROW(come_to_rest(m, 10, RestEnd::kEnd, ramp, hold), Error);   // 0.33 s before it, the ramp needs 0.5
  EXPECT_THROW(come_to_rest(m, 80, RestEnd::kStart, ramp, hold), Error);  // 0.33 s after it
  EXPECT_EQ(double_support_frame(s, slice_frames(m, 0, 3), RestEnd::kEnd), -1);
  // With room for a ramp: only frames with that much motion on their moving side are searched.
  const int late = double_support_frame(s, m, RestEnd::kEnd, 2.0), early = double_support_frame(s, m, RestEnd::kStart, 2.0);
  EXPECT_GE(late, 60);
  EXPECT_GE(early, 1);
  EXPECT_LE(early, 30);
  int best_late = 60;
  for (int t = 60; t <= 90; ++t) best_late = slower_at(t) < slower_at(best_late) ? t : best_late;
  EXPECT_EQ(late, best_late);
  EXPECT_EQ(double_support_frame(s, m, RestEnd::kEnd, 3.5), -1);  // longer than the motion
}

TEST(Augment, ResampleHalvesFramesAndInterpolates) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 121, 120.0);
  const Motion r = resample(m, 30.0);
  EXPECT_EQ(r.num_frames, 31);
  EXPECT_DOUBLE_EQ(r.fps, 30.0);
  EXPECT_NO_THROW(r.validate());
  for (int k = 0; k < r.num_frames; ++k)
    for (int j = 0; j < s.num_joints(); ++j) {
      EXPECT_LT(r.rotation(k, j).angularDistance(m.rotation(4 * k, j)), 1e-9);
      EXPECT_LT((r.translation(k, j) - m.translation(4 * k, j)).norm(), 1e-9);
    }
  // Between frames: the midpoint of two frames.
  const Motion two = resample(m, 240.0);
  EXPECT_EQ(two.num_frames, 241);
  EXPECT_LT((two.translation(1, 0) - 0.5 * (m.translation(0, 0) + m.translation(1, 0))).norm(), 1e-9);
  EXPECT_THROW(resample(m, 0.0), Error);
  // A rounded frame time (Bandai-Namco: 0.0333333 s) is the same rate: same frames, exact label.
  const Motion rounded = make_synthetic_walk(s, 31, 1.0 / 0.0333333);
  const Motion same = resample(rounded, 30.0);
  EXPECT_EQ(same.fps, 30.0);
  ASSERT_EQ(same.num_frames, 31);
  EXPECT_EQ(same.translations, rounded.translations);
}

TEST(Augment, TposeDetection) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.start_heading_rad = 0.0;
  Motion m = make_synthetic_walk(s, 30, 30.0, o);
  EXPECT_FALSE(looks_like_tpose(m));
  EXPECT_EQ(remove_tpose(m, TposeMode::kAuto).num_frames, 30);
  EXPECT_EQ(remove_tpose(m, TposeMode::kOn).num_frames, 29);
  // Glue a rest frame in front.
  Motion with = Motion::rest(s, 31, 30.0);
  for (int t = 0; t < 30; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      with.rotation(t + 1, j) = m.rotation(t, j);
      with.translation(t + 1, j) = m.translation(t, j);
    }
  EXPECT_TRUE(looks_like_tpose(with));
  const Motion removed = remove_tpose(with, TposeMode::kAuto);
  EXPECT_EQ(removed.num_frames, 30);
  EXPECT_LT(max_motion_difference(removed, m), 1e-12);
  EXPECT_EQ(remove_tpose(with, TposeMode::kOff).num_frames, 31);
  EXPECT_EQ(parse_tpose_mode("auto"), TposeMode::kAuto);
  EXPECT_THROW(parse_tpose_mode("yes"), Error);
}

TEST(Augment, StaticRootCollapses) {
  const Skeleton biped = make_synthetic_biped();
  Clip clip;
  clip.skeleton.joint_names.push_back("joint_Root");
  clip.skeleton.parents.push_back(-1);
  clip.skeleton.offsets.push_back(Eigen::Vector3d::Zero());
  for (int j = 0; j < biped.num_joints(); ++j) {
    clip.skeleton.joint_names.push_back(biped.joint_names[j]);
    clip.skeleton.parents.push_back(biped.parents[j] + 1);
    clip.skeleton.offsets.push_back(biped.offsets[j]);
  }
  for (EndSite e : biped.end_sites) clip.skeleton.end_sites.push_back({e.parent + 1, e.offset});
  const Motion walk = make_synthetic_walk(biped, 20, 30.0);
  clip.motion = Motion::rest(clip.skeleton, 20, 30.0);
  for (int t = 0; t < 20; ++t)
    for (int j = 0; j < biped.num_joints(); ++j) {
      clip.motion.rotation(t, j + 1) = walk.rotation(t, j);
      clip.motion.translation(t, j + 1) = walk.translation(t, j);
    }
  ASSERT_TRUE(has_static_root(clip));
  const Clip collapsed = collapse_static_root(clip);
  EXPECT_EQ(collapsed.skeleton.joint_names, biped.joint_names);
  EXPECT_EQ(collapsed.skeleton.parents, biped.parents);
  EXPECT_EQ(collapsed.skeleton.end_sites.size(), biped.end_sites.size());
  EXPECT_LT(max_motion_difference(collapsed.motion, walk), 1e-12);
  // A root that only translates (Bandai-Namco dataset 1) folds into Hips.
  Clip moving = clip;
  moving.motion.translation(5, 0) = Eigen::Vector3d(1, 0, 0);
  ASSERT_TRUE(has_static_root(moving));
  const Clip folded = collapse_static_root(moving);
  const WorldPoses wa = forward_kinematics(moving.skeleton, moving.motion);
  const WorldPoses wb = forward_kinematics(folded.skeleton, folded.motion);
  for (int t = 0; t < 20; ++t)
    for (int j = 0; j < biped.num_joints(); ++j) EXPECT_LT((wa.position(t, j + 1) - wb.position(t, j)).norm(), 1e-9);
  // A root that rotates is kept.
  Clip rotating = clip;
  rotating.motion.rotation(3, 0) = Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()));
  EXPECT_FALSE(has_static_root(rotating));
  EXPECT_EQ(collapse_static_root(rotating).skeleton.num_joints(), clip.skeleton.num_joints());
  EXPECT_FALSE(has_static_root(collapsed));
}

TEST(Augment, JointSubsetByGlob) {
  Clip clip;
  clip.skeleton = make_synthetic_biped();
  clip.motion = make_synthetic_walk(clip.skeleton, 10, 30.0);
  const Clip no_hands = subset_by_patterns(clip, {"Hand_*", "Toes*"}, {});
  EXPECT_EQ(no_hands.skeleton.num_joints(), 17);
  EXPECT_EQ(no_hands.skeleton.find("Hand_L"), -1);
  const Clip legs = subset_by_patterns(clip, {}, {"*Leg*", "Foot_?"});
  EXPECT_EQ(legs.skeleton.num_joints(), 7);  // Hips + 2 x (UpperLeg, LowerLeg, Foot)
  EXPECT_EQ(legs.skeleton.joint_names[0], "Hips");
  // World positions of kept joints are unchanged.
  const WorldPoses a = forward_kinematics(clip.skeleton, clip.motion);
  const WorldPoses b = forward_kinematics(legs.skeleton, legs.motion);
  const int foot = clip.skeleton.find("Foot_R"), foot_sub = legs.skeleton.find("Foot_R");
  for (int t = 0; t < 10; ++t) EXPECT_LT((a.position(t, foot) - b.position(t, foot_sub)).norm(), 1e-9);
  EXPECT_THROW(subset_by_patterns(clip, {"Hip*"}, {}), Error);
}

std::string data_cache() { return MOSYN_DATA_CACHE; }

TEST(RealDataAugment, BandaiMirrorAndCmuTpose) {
  const std::string bandai =
      data_cache() + "/bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk-turn-left_normal_001.bvh";
  const std::string cmu = data_cache() + "/cmu-mocap-subset/bvh/02/02_01.bvh";
  if (!std::filesystem::exists(bandai) || !std::filesystem::exists(cmu)) GTEST_SKIP() << "shared data not unpacked";
  const Clip clip = collapse_static_root(io::to_clip(io::read_bvh(bandai)));
  EXPECT_EQ(clip.skeleton.num_joints(), 21);
  const MirrorPlan plan = plan_mirror(clip.skeleton);
  EXPECT_EQ(clip.skeleton.joint_names[plan.map[clip.skeleton.find("Hand_L")]], "Hand_R");
  // Bandai's offsets are symmetric to within a fraction of a millimetre.
  EXPECT_LT(mirror_position_error(clip.skeleton, clip.motion, plan), 2e-3);
  EXPECT_LT(max_motion_difference(mirror(clip.skeleton, mirror(clip.skeleton, clip.motion, plan), plan), clip.motion),
            1e-9);
  // A left turn mirrored turns right.
  const Eigen::Vector3d fwd = estimate_forward_in_root(clip.skeleton);
  const GroundTrajectory g0 = ground_trajectory(clip.skeleton, clip.motion, 0, fwd);
  const GroundTrajectory g1 = ground_trajectory(clip.skeleton, mirror(clip.skeleton, clip.motion, plan), 0, fwd);
  const double turn0 = g0.headings_rad.back() - g0.headings_rad.front();
  const double turn1 = g1.headings_rad.back() - g1.headings_rad.front();
  EXPECT_GT(turn0, 0.5);
  EXPECT_NEAR(turn1, -turn0, 0.05);
  EXPECT_FALSE(looks_like_tpose(clip.motion));

  const Clip c = io::to_clip(io::read_bvh(cmu));
  EXPECT_TRUE(looks_like_tpose(c.motion));
  EXPECT_FALSE(looks_like_tpose(remove_tpose(c.motion, TposeMode::kAuto)));
  const Motion at30 = resample(remove_tpose(c.motion, TposeMode::kAuto), 30.0);
  EXPECT_NEAR(at30.fps, 30.0, 1e-12);
  EXPECT_NEAR(at30.num_frames, (c.motion.num_frames - 1) / 4.0, 2.0);
}

TEST(RealDataAugment, TposeFoundInEveryCmuFileAndNoBandaiFile) {
  const std::string cmu = data_cache() + "/cmu-mocap-subset";
  const std::string bandai = data_cache() + "/bandai-namco/Bandai-Namco-Research-Motiondataset-2";
  if (!std::filesystem::exists(cmu) || !std::filesystem::exists(bandai)) GTEST_SKIP() << "shared data not unpacked";
  const SourceListing c = list_source(cmu);
  EXPECT_EQ(c.files.size(), 81u);
  for (const SourceFile& f : c.files) {
    const int n = count_leading_rest_frames(io::to_clip(io::read_bvh(f.path)).motion);
    EXPECT_GE(n, 1) << f.relative;
    EXPECT_LE(n, 5) << f.relative;
  }
  SourceListing b = list_source(bandai);
  filter_source(&b, {}, {"normal"});
  for (size_t i = 0; i < b.files.size(); i += 7)
    EXPECT_EQ(count_leading_rest_frames(io::to_clip(io::read_bvh(b.files[i].path)).motion), 0) << b.files[i].relative;
}

TEST(RealDataAugment, BandaiDataset1RootFoldsIntoHips) {
  const std::string path =
      data_cache() + "/bandai-namco/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk_normal_002.bvh";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared data not unpacked";
  const Clip clip = io::to_clip(io::read_bvh(path));
  ASSERT_TRUE(has_static_root(clip));
  const Clip folded = collapse_static_root(clip);
  EXPECT_EQ(folded.skeleton.joint_names[0], "Hips");
  const WorldPoses a = forward_kinematics(clip.skeleton, clip.motion);
  const WorldPoses b = forward_kinematics(folded.skeleton, folded.motion);
  for (int t = 0; t < clip.motion.num_frames; ++t)
    for (int j = 0; j < folded.skeleton.num_joints(); ++j)
      ASSERT_LT((a.position(t, j + 1) - b.position(t, j)).norm(), 1e-6);
}

}  // namespace
}  // namespace mosyn::data
