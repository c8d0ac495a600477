#include "data/representation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "core/units.h"
#include "data/augment.h"
#include "io/bvh.h"

namespace mosyn::data {
namespace {

// Largest world-position difference over all frames and joints, in skeleton units.
double max_position_error(const Skeleton& skeleton, const Motion& a, const Motion& b) {
  const WorldPoses wa = forward_kinematics(skeleton, a);
  const WorldPoses wb = forward_kinematics(skeleton, b);
  double worst = 0;
  for (size_t i = 0; i < wa.positions.size(); ++i) worst = std::max(worst, (wa.positions[i] - wb.positions[i]).norm());
  return worst;
}

// Encodes, decodes from the clip's own start, and returns the worst position error divided by
// the skeleton's estimated height.
double round_trip_error(const Skeleton& skeleton, const Motion& motion, PoseForm form, int root_joint = 0,
                        double root_smoothing_s = 0.0) {
  const FeatureLayout layout =
      make_layout(skeleton, form, root_joint, estimate_forward_in_root(skeleton), root_smoothing_s);
  std::vector<float> pose, control;
  encode(skeleton, motion, layout, &pose, &control);
  EXPECT_EQ(pose.size(), static_cast<size_t>(motion.num_frames) * layout.pose_dim);
  EXPECT_EQ(control.size(), static_cast<size_t>(motion.num_frames) * 3);
  const GroundTrajectory g = ground_trajectory(skeleton, motion, root_joint, layout.forward_in_root);
  const Motion back = decode(skeleton, layout, pose.data(), control.data(), motion.num_frames, motion.fps,
                             g.positions[0], g.headings_rad[0]);
  EXPECT_NO_THROW(back.validate());
  return max_position_error(skeleton, motion, back) / estimate_height_units(skeleton);
}

TEST(Representation, LayoutDimsAndNames) {
  const Skeleton s = make_synthetic_biped();
  const FeatureLayout rot = make_layout(s, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(rot.pose_dim, 1 + 6 * 21);
  EXPECT_EQ(rot.pose_names.front(), "Hips.height_m");
  EXPECT_EQ(rot.pose_names[1], "Hips.heading_r6d0");
  EXPECT_EQ(rot.pose_names[7], "Spine.r6d0");
  EXPECT_EQ(rot.control_names, (std::vector<std::string>{"dx_m", "dz_m", "dtheta_rad"}));
  const FeatureLayout pos = make_layout(s, PoseForm::kPositions, 0, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(pos.pose_dim, 3 * 21);
  EXPECT_EQ(pos.pose_names[4], "Spine.y_m");
  EXPECT_EQ(parse_pose_form("positions"), PoseForm::kPositions);
  EXPECT_STREQ(to_string(PoseForm::kRotations), "rotations");
  EXPECT_THROW(parse_pose_form("quaternions"), Error);
  EXPECT_THROW(make_layout(s, PoseForm::kRotations, 21, Eigen::Vector3d(0, 0, 1)), Error);
}

TEST(Representation, FeaturesOfAStraightWalk) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.speed_mps = 1.5;
  o.start_heading_rad = 1.0;
  o.sway_rad = 0.0;
  const Motion m = make_synthetic_walk(s, 60, 30.0, o);
  const FeatureLayout layout = make_layout(s, PoseForm::kPositions, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  encode(s, m, layout, &pose, &control);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(control[k], 0.0f);
  for (int t = 1; t < 60; ++t) {
    EXPECT_NEAR(control[3 * t + 0], 0.0, 1e-4);          // no sideways motion
    EXPECT_NEAR(control[3 * t + 1], 1.5 / 30.0, 1e-3);   // forward metres per frame
    EXPECT_NEAR(control[3 * t + 2], 0.0, 1e-6);          // no turning
    // Root sits above the floor-projected root: (0, height, 0), height about 0.96 m.
    EXPECT_NEAR(pose[t * layout.pose_dim + 0], 0.0, 1e-5);
    EXPECT_NEAR(pose[t * layout.pose_dim + 1], 0.96, 0.05);
    EXPECT_NEAR(pose[t * layout.pose_dim + 2], 0.0, 1e-5);
  }
}

TEST(Representation, RoundTripTurningWalkBothForms) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.8;
  o.noise_rad = 0.02;
  o.seed = 3;
  const Motion m = make_synthetic_walk(s, 240, 30.0, o);
  EXPECT_LT(round_trip_error(s, m, PoseForm::kRotations), 1e-4);
  EXPECT_LT(round_trip_error(s, m, PoseForm::kPositions), 1e-4);
}

TEST(Representation, SmoothedRootLayout) {
  const Skeleton s = make_synthetic_biped();
  const FeatureLayout rot = make_layout(s, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1), 0.2);
  EXPECT_EQ(rot.pose_dim, 1 + 6 * 21 + 2);
  EXPECT_EQ(rot.pose_names[rot.pose_dim - 2], "Hips.offset_x_m");
  EXPECT_EQ(rot.pose_names[rot.pose_dim - 1], "Hips.offset_z_m");
  EXPECT_TRUE(rot.smoothed_root());
  const FeatureLayout pos = make_layout(s, PoseForm::kPositions, 0, Eigen::Vector3d(0, 0, 1), 0.2);
  EXPECT_EQ(pos.pose_dim, 3 * 21);
  EXPECT_EQ(expected_pose_dim(PoseForm::kRotations, 21, true), 129);
  EXPECT_THROW(make_layout(s, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1), -0.1), Error);
  EXPECT_THROW(make_layout(s, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1), 11.0), Error);
}

TEST(Representation, RoundTripSmoothedRootBothForms) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.8;
  o.noise_rad = 0.02;
  o.sway_rad = 0.1;
  o.seed = 5;
  const Motion m = make_synthetic_walk(s, 240, 30.0, o);
  for (double sigma : {0.1, 0.2, 0.5}) {
    EXPECT_LT(round_trip_error(s, m, PoseForm::kRotations, 0, sigma), 1e-4) << sigma;
    EXPECT_LT(round_trip_error(s, m, PoseForm::kPositions, 0, sigma), 1e-4) << sigma;
  }
}

// The smoothed control keeps the path (same start and end, same mean speed) but loses the gait's
// rhythm, which moves into the pose: the hip's yaw oscillation relative to the trajectory and its
// offset from it.
TEST(Representation, SmoothedControlLosesTheGaitRhythm) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.sway_rad = 0.1;
  o.cycle_hz = 1.0;
  o.speed_mps = 1.2;
  const int frames = 300;
  const Motion m = make_synthetic_walk(s, frames, 30.0, o);
  const FeatureLayout raw = make_layout(s, PoseForm::kRotations, 0, estimate_forward_in_root(s));
  const FeatureLayout smooth = make_layout(s, PoseForm::kRotations, 0, estimate_forward_in_root(s), 0.4);
  std::vector<float> pose_raw, control_raw, pose_smooth, control_smooth;
  encode(s, m, raw, &pose_raw, &control_raw);
  encode(s, m, smooth, &pose_smooth, &control_smooth);
  // Spread of the turn rate over the middle of the clip (the walk is straight on average).
  auto turn_std = [&](const std::vector<float>& c) {
    double sum = 0, sum2 = 0;
    int n = 0;
    for (int t = 60; t < frames - 60; ++t, ++n) {
      sum += c[3 * t + 2];
      sum2 += c[3 * t + 2] * c[3 * t + 2];
    }
    return std::sqrt(std::max(0.0, sum2 / n - (sum / n) * (sum / n)));
  };
  EXPECT_GT(turn_std(control_raw), 0.005);
  EXPECT_LT(turn_std(control_smooth), 0.1 * turn_std(control_raw));
  // Both controls integrate to the same end point (the filter keeps the ends).
  const GroundTrajectory g_raw = ground_trajectory(s, m, 0, raw.forward_in_root);
  const GroundTrajectory g_smooth = control_trajectory(s, m, smooth);
  EXPECT_LT((g_raw.positions.front() - g_smooth.positions.front()).norm(), 1e-9);
  EXPECT_LT((g_raw.positions.back() - g_smooth.positions.back()).norm(), 1e-9);
  EXPECT_NEAR(g_raw.headings_rad.back(), g_smooth.headings_rad.back(), 1e-9);
}

TEST(Representation, RoundTripWithStaticRootAbove) {
  // A Bandai-like skeleton whose joint 0 is a static root and whose trajectory joint is 1.
  const Skeleton biped = make_synthetic_biped();
  Skeleton s;
  s.joint_names.push_back("joint_Root");
  s.parents.push_back(-1);
  s.offsets.push_back(Eigen::Vector3d::Zero());
  for (int j = 0; j < biped.num_joints(); ++j) {
    s.joint_names.push_back(biped.joint_names[j]);
    s.parents.push_back(biped.parents[j] + 1);
    s.offsets.push_back(biped.offsets[j]);
  }
  s.meters_per_unit = biped.meters_per_unit;
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = -0.6;
  const Motion walk = make_synthetic_walk(biped, 90, 30.0, o);
  Motion m = Motion::rest(s, 90, 30.0);
  for (int t = 0; t < 90; ++t)
    for (int j = 0; j < biped.num_joints(); ++j) {
      m.rotation(t, j + 1) = walk.rotation(t, j);
      m.translation(t, j + 1) = walk.translation(t, j);
    }
  EXPECT_LT(round_trip_error(s, m, PoseForm::kRotations, 1), 1e-4);
  EXPECT_LT(round_trip_error(s, m, PoseForm::kPositions, 1), 1e-4);
  EXPECT_LT(round_trip_error(s, m, PoseForm::kRotations, 1, 0.2), 1e-4);
  EXPECT_LT(round_trip_error(s, m, PoseForm::kPositions, 1, 0.2), 1e-4);
}

TEST(Representation, DecodeStartsWhereAsked) {
  const Skeleton s = make_synthetic_biped();
  const Motion m = make_synthetic_walk(s, 10, 30.0);
  const FeatureLayout layout = make_layout(s, PoseForm::kRotations, 0, estimate_forward_in_root(s));
  std::vector<float> pose, control;
  encode(s, m, layout, &pose, &control);
  const Motion back = decode(s, layout, pose.data(), control.data(), 10, 30.0, Eigen::Vector3d(100, 50, -20), 0.0);
  EXPECT_NEAR(back.translation(0, 0).x(), 100, 1e-6);
  EXPECT_NEAR(back.translation(0, 0).z(), -20, 1e-6);
  EXPECT_NEAR(back.translation(0, 0).y() * s.meters_per_unit, pose[0], 1e-6);
  const GroundTrajectory g = ground_trajectory(s, back, 0, layout.forward_in_root);
  EXPECT_NEAR(g.headings_rad[0], 0.0, 1e-6);
}

TEST(Representation, RejectsMismatchedMotion) {
  const Skeleton s = make_synthetic_biped();
  const FeatureLayout layout = make_layout(s, PoseForm::kRotations, 0, Eigen::Vector3d(0, 0, 1));
  Skeleton other = s;
  other.joint_names.pop_back();
  other.parents.pop_back();
  other.offsets.pop_back();
  other.end_sites.clear();
  const Motion m = Motion::rest(other, 3, 30.0);
  std::vector<float> pose, control;
  EXPECT_THROW(encode(s, m, layout, &pose, &control), Error);
  EXPECT_THROW(encode(other, m, layout, &pose, &control), Error);
}

// Real data: a Bandai-Namco walk (joint_Root collapsed) and a CMU clip (T-pose kept: it is
// still a valid pose), both forms.
std::string data_cache() { return MOSYN_DATA_CACHE; }

TEST(RealDataRepresentation, RoundTripBandaiAndCmu) {
  const std::string bandai =
      data_cache() + "/bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk-turn-left_normal_001.bvh";
  const std::string cmu = data_cache() + "/cmu-mocap-subset/bvh/02/02_01.bvh";
  if (!std::filesystem::exists(bandai) || !std::filesystem::exists(cmu)) GTEST_SKIP() << "shared data not unpacked";
  {
    Clip clip = collapse_static_root(io::to_clip(io::read_bvh(bandai)));
    clip.skeleton.meters_per_unit = guess_meters_per_unit(clip.skeleton);
    EXPECT_EQ(clip.skeleton.joint_names[0], "Hips");
    EXPECT_LT(round_trip_error(clip.skeleton, clip.motion, PoseForm::kRotations), 1e-4);
    EXPECT_LT(round_trip_error(clip.skeleton, clip.motion, PoseForm::kPositions), 1e-4);
  }
  {
    Clip clip = io::to_clip(io::read_bvh(cmu));
    clip.skeleton.meters_per_unit = guess_meters_per_unit(clip.skeleton);
    EXPECT_LT(round_trip_error(clip.skeleton, clip.motion, PoseForm::kRotations), 1e-4);
    EXPECT_LT(round_trip_error(clip.skeleton, clip.motion, PoseForm::kPositions), 1e-4);
  }
}

}  // namespace
}  // namespace mosyn::data
