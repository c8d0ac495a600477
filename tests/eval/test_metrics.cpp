// Metrics against hand-computed values on tiny synthetic inputs.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/synthetic.h"
#include "metrics/metrics.h"
#include "metrics/set_metrics.h"

namespace mosyn::eval {
namespace {

// A Y-up figure of a root and two feet; feet follow the given horizontal x tracks (metres) on the
// floor, or at the given heights.
MotionPositions two_feet(const std::vector<double>& left_x, const std::vector<double>& right_x, double fps,
                         const std::vector<double>& left_y = {}) {
  MotionPositions m;
  m.fps = fps;
  m.num_frames = static_cast<int>(left_x.size());
  m.num_joints = 3;
  m.up_axis = 1;
  m.joint_names = {"Hips", "Foot_L", "Foot_R"};
  m.parents = {-1, 0, 0};
  m.bone_lengths_m = {0, 1, 1};
  for (int t = 0; t < m.num_frames; ++t) {
    m.positions_m.emplace_back(0, 1, 0);
    m.positions_m.emplace_back(left_x[t], left_y.empty() ? 0.0 : left_y[t], 0.1);
    m.positions_m.emplace_back(right_x[t], 0, -0.1);
  }
  return m;
}

// Positions from per-sample speeds (m/s) along x.
std::vector<double> integrate(const std::vector<double>& speeds, double fps) {
  std::vector<double> x = {0.0};
  for (double v : speeds) x.push_back(x.back() + v / fps);
  return x;
}

TEST(FootTest, FindsFeetByName) {
  const Clip clip{make_synthetic_biped(), {}};
  Clip c = clip;
  c.motion = Motion::rest(c.skeleton, 2, 30);
  const MotionPositions m = motion_positions(c);
  const FootJoints f = find_foot_joints(m);
  EXPECT_EQ(m.joint_names[f.left_heel], "Foot_L");
  EXPECT_EQ(m.joint_names[f.right_heel], "Foot_R");
  EXPECT_EQ(m.joint_names[f.left_toe], "Toes_L");
  EXPECT_EQ(m.joint_names[f.right_toe], "Toes_R");
  // Centimetres guessed: the hips stand 0.96 m high.
  EXPECT_NEAR(m.position(0, 0).y(), 0.96, 1e-12);

  MotionPositions cmu;
  cmu.joint_names = {"Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase", "RightUpLeg", "RightLeg",
                     "RightFoot", "RightToeBase"};
  cmu.parents = {-1, 0, 1, 2, 3, 0, 5, 6, 7};
  cmu.num_joints = 9;
  const FootJoints g = find_foot_joints(cmu);
  EXPECT_EQ(g.left_heel, 3);
  EXPECT_EQ(g.right_heel, 7);
  EXPECT_EQ(g.left_toe, 4);
  EXPECT_EQ(g.right_toe, 8);
  const FootJoints h = find_foot_joints(cmu, {"LeftLeg", "RightLeg"});
  EXPECT_EQ(h.left_heel, 2);
  EXPECT_EQ(h.right_heel, 6);
  EXPECT_THROW(find_foot_joints(cmu, {"LeftLeg", "Nope"}), Error);
}

TEST(FootstepTest, DurationsOfRuns) {
  const auto d = footstep_durations_s({0, 0, 0, 1, 1, 0, 0, 1}, 10.0, 0.5);
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NEAR(d[0], 0.3, 1e-12);
  EXPECT_NEAR(d[1], 0.2, 1e-12);
  EXPECT_TRUE(footstep_durations_s({1, 1}, 10.0, 0.5).empty());
}

TEST(FootstepTest, KnownStepTimesAndTolerance) {
  const double fps = 10;
  std::vector<double> left(5, 0.0), right = {1, 1};
  left.insert(left.end(), 4, 1.0);
  left.insert(left.end(), 5, 0.0);
  right.insert(right.end(), 8, 0.205);  // a sliding contact
  right.insert(right.end(), 4, 1.0);
  const MotionPositions m = two_feet(integrate(left, fps), integrate(right, fps), fps);
  const FootstepAnalysis a = analyse_footsteps({m}, {find_foot_joints(m)});
  ASSERT_EQ(a.f_est.size(), 100u);
  EXPECT_EQ(a.f_est[0], 2);    // 1 cm/s: only the still steps
  EXPECT_EQ(a.f_est[19], 2);   // 20 cm/s
  EXPECT_EQ(a.f_est[20], 3);   // 21 cm/s: the sliding contact counts
  EXPECT_EQ(a.max_steps, 3);
  EXPECT_NEAR(a.v_tol95_mps, 0.21, 1e-12);
  EXPECT_EQ(a.steps_at_v_tol95, 3);
  EXPECT_NEAR(a.step_duration_mean_s, 0.6, 1e-12);          // 0.5, 0.5, 0.8
  EXPECT_NEAR(a.step_duration_std_s, std::sqrt(0.02), 1e-12);
  // At the fixed 15 cm/s the sliding contact (20.5 cm/s) is no contact: two of 0.5 s over two feet'
  // tracks of 1.4 s each.
  EXPECT_NEAR(a.contacts_per_foot_s, 2 / 2.8, 1e-12);
  EXPECT_NEAR(a.contact_mean_at_fixed_tol_s, 0.5, 1e-12);
  FootstepOptions loose;
  loose.fixed_tol_mps = 0.3;
  const FootstepAnalysis c = analyse_footsteps({m}, {find_foot_joints(m)}, loose);
  EXPECT_NEAR(c.contacts_per_foot_s, 3 / 2.8, 1e-12);
  EXPECT_NEAR(c.contact_mean_at_fixed_tol_s, 0.6, 1e-12);
  loose.fixed_tol_mps = 0;
  EXPECT_THROW(analyse_footsteps({m}, {find_foot_joints(m)}, loose), Error);
  // Runs shorter than the minimum (here 0.6 s) are not steps: only the 0.8 s contact remains.
  FootstepOptions o;
  o.min_step_duration_s = 0.6;
  o.v_tol_max_mps = 0.5;  // below the 1 m/s swings, which would merge runs
  const FootstepAnalysis b = analyse_footsteps({m}, {find_foot_joints(m)}, o);
  EXPECT_EQ(b.f_est[0], 0);
  EXPECT_EQ(b.max_steps, 1);
  EXPECT_NEAR(b.v_tol95_mps, 0.21, 1e-12);
  EXPECT_NEAR(b.step_duration_mean_s, 0.8, 1e-12);
}

TEST(FootSkatingTest, SlidingFootAtKnownSpeed) {
  const double fps = 10;
  const MotionPositions m = two_feet(integrate(std::vector<double>(10, 0.5), fps), std::vector<double>(11, 0.0), fps);
  const auto speed = horizontal_speed_mps(m, 1);
  ASSERT_EQ(speed.size(), 10u);
  for (double v : speed) EXPECT_NEAR(v, 0.5, 1e-12);
  const FootJoints f = find_foot_joints(m);
  FootSkatingOptions o;
  o.both_feet = false;  // one sliding foot counts
  EXPECT_DOUBLE_EQ(foot_skating_ratio(m, f, o), 1.0);
  EXPECT_DOUBLE_EQ(foot_skating_ratio(m, f), 0.0);  // MOJO: both feet must slide
  o.speed_threshold_mps = 0.6;
  EXPECT_DOUBLE_EQ(foot_skating_ratio(m, f, o), 0.0);
  // Lifted 10 cm from frame 5 on: only transitions 0->1 .. 3->4 are near the ground.
  std::vector<double> y(11, 0.0);
  for (int t = 5; t <= 10; ++t) y[t] = 0.1;
  const MotionPositions lifted =
      two_feet(integrate(std::vector<double>(10, 0.5), fps), std::vector<double>(11, 0.0), fps, y);
  o.speed_threshold_mps = 0.075;
  EXPECT_NEAR(foot_skating_ratio(lifted, f, o), 0.4, 1e-12);
  // Both feet sliding at 0.5 m/s: every transition skates under either reading.
  const std::vector<double> both = integrate(std::vector<double>(10, 0.5), fps);
  EXPECT_DOUBLE_EQ(foot_skating_ratio(two_feet(both, both, fps), f), 1.0);
}

// Toe sliding by hand (the independent check's rule): 21 frames at 10 fps. The left toe slides at
// 0.5 m/s over transitions 0->1 .. 4->5, stands, and swings at 1 m/s lifted 5 cm from frame 10 on
// (not counted: it is off its floor); the right toe creeps at 5 cm/s (under the 10 cm/s bar), slides
// at 0.2 m/s over 12->13 and 13->14, and has one stray frame 50 cm under its floor (frame 15), which
// the 5th-percentile floor ignores and the lowest point does not.
TEST(FootSkatingTest, ToeSlideRatioByHand) {
  const double fps = 10;
  const int frames = 21;
  std::vector<double> left(frames - 1, 0.0), right(frames - 1, 0.05);
  for (int t = 0; t < 5; ++t) left[t] = 0.5;
  for (int t = 10; t < frames - 1; ++t) left[t] = 1.0;
  right[12] = right[13] = 0.2;
  std::vector<double> left_y(frames, 0.0);
  for (int t = 10; t < frames; ++t) left_y[t] = 0.05;
  MotionPositions m = two_feet(integrate(left, fps), integrate(right, fps), fps, left_y);
  m.positions_m[15 * 3 + 2].y() = -0.5;
  FootJoints toes;
  toes.left_toe = 1;
  toes.right_toe = 2;
  EXPECT_NEAR(toe_slide_ratio(m, toes), 7.0 / 20, 1e-12);
  ToeSlideOptions o;
  o.floor_percentile = 0;  // the lowest point: the right toe's floor drops to -0.5 m
  EXPECT_NEAR(toe_slide_ratio(m, toes, o), 5.0 / 20, 1e-12);
  o = {};
  o.speed_threshold_mps = 0.6;
  EXPECT_DOUBLE_EQ(toe_slide_ratio(m, toes, o), 0.0);
  EXPECT_TRUE(std::isnan(toe_slide_ratio(m, find_foot_joints(m))));  // Foot_L / Foot_R: heels, no toes
  o = {};
  o.floor_percentile = 101;
  EXPECT_THROW(toe_slide_ratio(m, toes, o), mosyn::Error);
  o = {};
  o.height_threshold_m = 0;
  EXPECT_THROW(toe_slide_ratio(m, toes, o), mosyn::Error);
}

// The slower heel's speed: a walk alternates the planted foot, so it stays at zero; a glide moves
// both, so it is the slower one's speed.
TEST(FootSkatingTest, SlowerFootSpeedByHand) {
  const double fps = 10;
  // Left swings at 1 m/s for 5 transitions, then right swings, the other planted: a walk.
  std::vector<double> left(10, 0.0), right(10, 0.0);
  for (int t = 0; t < 5; ++t) left[t] = 1.0;
  for (int t = 5; t < 10; ++t) right[t] = 1.0;
  const MotionPositions walk = two_feet(integrate(left, fps), integrate(right, fps), fps);
  const std::vector<double> v = slower_foot_speed_mps(walk, find_foot_joints(walk));
  ASSERT_EQ(v.size(), 10u);
  for (double x : v) EXPECT_NEAR(x, 0.0, 1e-12);
  // Both feet gliding, at 0.3 and 0.5 m/s: the slower one's 0.3 at every transition.
  const MotionPositions glide =
      two_feet(integrate(std::vector<double>(10, 0.5), fps), integrate(std::vector<double>(10, 0.3), fps), fps);
  for (double x : slower_foot_speed_mps(glide, find_foot_joints(glide))) EXPECT_NEAR(x, 0.3, 1e-12);
  EXPECT_TRUE(slower_foot_speed_mps(two_feet({0.0}, {0.0}, fps), find_foot_joints(walk)).empty());
}

// The pelvis' ground speed over 1-s spans, by hand: a sway of period 1 s cancels over a span, the
// height is ignored, and a motion shorter than the span counts once over its length.
TEST(PelvisGroundSpeedTest, SpansAverageTheSwayOut) {
  const double fps = 10, pi = 3.14159265358979;
  MotionPositions walk = two_feet(std::vector<double>(21, 0.0), std::vector<double>(21, 0.0), fps);
  for (int t = 0; t < walk.num_frames; ++t)  // 1.2 m/s along x, 5 cm sway along z, 3 cm bob
    walk.positions_m[static_cast<size_t>(t) * 3] =
        Eigen::Vector3d(1.2 * t / fps, 1.0 + 0.03 * std::sin(4 * pi * t / fps), 0.05 * std::sin(2 * pi * t / fps));
  EXPECT_NEAR(pelvis_ground_speed_mps({walk}), 1.2, 1e-9);  // 11 spans of 10 frames
  // Per frame the sway adds speed, so the span is what reads the path's speed.
  EXPECT_NEAR(horizontal_speed_mps(walk, 0)[0], std::hypot(1.2, 0.05 * std::sin(2 * pi / fps) * fps), 1e-9);
  MotionPositions brief = two_feet(std::vector<double>(5, 0.0), std::vector<double>(5, 0.0), fps);
  for (int t = 0; t < brief.num_frames; ++t) brief.positions_m[static_cast<size_t>(t) * 3] = Eigen::Vector3d(0, 1, 0.5 * t / fps);
  EXPECT_NEAR(pelvis_ground_speed_mps({brief}), 0.5, 1e-9);
  EXPECT_NEAR(pelvis_ground_speed_mps({walk, brief}), (11 * 1.2 + 0.5) / 12, 1e-9);  // spans pooled
  EXPECT_TRUE(std::isnan(pelvis_ground_speed_mps({})));
  EXPECT_THROW(pelvis_ground_speed_mps({walk}, 0.0), Error);
}

TEST(BodyValidityTest, BoneLengthAndDeformation) {
  MotionPositions m;
  m.fps = 10;
  m.num_frames = 2;
  m.num_joints = 2;
  m.joint_names = {"Neck", "Head"};
  m.parents = {-1, 0};
  m.bone_lengths_m = {0, 1.0};
  m.positions_m = {{0, 0, 0}, {0, 1.1, 0}, {0, 0, 0}, {0, 0.9, 0}};
  EXPECT_NEAR(bone_length_rmse_m(m), 0.1, 1e-12);
  EXPECT_NEAR(rigid_part_deformation_m(m, {"head", {0, 1}}), 0.1, 1e-12);
  const auto parts = default_rigid_parts(m);
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].name, "head");
}

TEST(BodyValidityTest, SyntheticBipedPartsAndExactBones) {
  Clip c{make_synthetic_biped(), {}};
  c.motion = make_synthetic_walk(c.skeleton, 30, 30.0);
  const MotionPositions m = motion_positions(c);
  EXPECT_LT(bone_length_rmse_m(m), 1e-9);
  const auto parts = default_rigid_parts(m);
  ASSERT_EQ(parts.size(), 3u);
  EXPECT_EQ(parts[0].joints, (std::vector<int>{3, 4}));
  EXPECT_EQ(parts[1].joints, (std::vector<int>{2, 3, 5, 9}));
  EXPECT_EQ(parts[2].joints, (std::vector<int>{0, 1, 13, 17}));
  // Hips, spine and upper legs hang off one rigid joint: no deformation under FK.
  EXPECT_LT(rigid_part_deformation_m(m, parts[2]), 1e-9);
}

TEST(PredictionTest, ApdOfIdenticalAndOffsetSamples) {
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(5, 6);
  EXPECT_DOUBLE_EQ(average_pairwise_distance({a, a, a}), 0.0);
  // Offset 2 in every entry: distance 2 * sqrt(30) for each pair.
  const Eigen::MatrixXd b = a.array() + 2.0;
  EXPECT_NEAR(average_pairwise_distance({a, b}), 2 * std::sqrt(30.0), 1e-12);
  // Three samples on a line at 0, 1, 3 (one entry): pairs 1, 3, 2 -> mean 2.
  Eigen::MatrixXd z = Eigen::MatrixXd::Zero(1, 1), o = z, t = z;
  o(0, 0) = 1;
  t(0, 0) = 3;
  EXPECT_NEAR(average_pairwise_distance({z, o, t}), 2.0, 1e-12);
}

TEST(PredictionTest, AdeFdeOfKnownOffsets) {
  const Eigen::MatrixXd gt = Eigen::MatrixXd::Zero(4, 3);
  Eigen::MatrixXd a = gt, b = gt;
  a.col(0).setConstant(3);
  a.col(1).setConstant(4);  // 5 m off at every frame
  b.col(0) << 1, 1, 1, 10;  // 1 m off, then 10 m at the end
  EXPECT_NEAR(average_displacement_error({a, b}, gt), 3.25, 1e-12);
  EXPECT_NEAR(final_displacement_error({a, b}, gt), 5.0, 1e-12);
  Eigen::MatrixXd gt2 = gt;
  gt2.col(2).setConstant(1);
  const double ade2 = std::min(std::sqrt(26.0), (3 * std::sqrt(2.0) + std::sqrt(101.0)) / 4);
  const double fde2 = std::min(std::sqrt(26.0), std::sqrt(101.0));
  EXPECT_NEAR(multimodal_ade({a, b}, {gt, gt2}), (3.25 + ade2) / 2, 1e-12);
  EXPECT_NEAR(multimodal_fde({a, b}, {gt, gt2}), (5.0 + fde2) / 2, 1e-12);
  EXPECT_THROW(average_displacement_error({Eigen::MatrixXd::Zero(3, 3)}, gt), Error);
}

TEST(PredictionTest, JointPositionErrorsByHand) {
  // Two joints, three frames; the sample is offset per joint and frame by known vectors.
  const Eigen::MatrixXd gt = Eigen::MatrixXd::Random(3, 6);
  Eigen::MatrixXd s = gt;
  s.row(1).segment(0, 3) += Eigen::Vector3d(3, 4, 0).transpose();   // joint 0: 5 m
  s.row(1).segment(3, 3) += Eigen::Vector3d(0, 0, 1).transpose();   // joint 1: 1 m
  s.row(2).segment(3, 3) += Eigen::Vector3d(2, 0, 0).transpose();   // joint 1: 2 m
  const auto e = joint_position_errors_m(s, gt, {2, 0, 1});
  ASSERT_EQ(e.size(), 3u);
  EXPECT_NEAR(e[0], 1.0, 1e-12);  // (0 + 2) / 2
  EXPECT_NEAR(e[1], 0.0, 1e-12);
  EXPECT_NEAR(e[2], 3.0, 1e-12);  // (5 + 1) / 2
  // Only the requested frames must exist in both sequences.
  EXPECT_NEAR(joint_position_errors_m(s.topRows(2), gt, {1})[0], 3.0, 1e-12);
  EXPECT_THROW(joint_position_errors_m(s, gt, {3}), Error);
  EXPECT_THROW(joint_position_errors_m(s.topRows(2), gt, {2}), Error);
  EXPECT_THROW(joint_position_errors_m(s.leftCols(5), gt.leftCols(5), {0}), Error);
  EXPECT_THROW(joint_position_errors_m(s, gt.leftCols(3), {0}), Error);
}

TEST(PredictionTest, EvaluatePredictionsOverWindows) {
  // Two windows with the same last context pose (one multi-modal group), one far away.
  const Eigen::MatrixXd zero = Eigen::MatrixXd::Zero(3, 2);
  const Eigen::MatrixXd one = Eigen::MatrixXd::Constant(3, 2, 1.0);  // sqrt(2) per frame from zero
  std::vector<PredictionWindow> w(3);
  w[0] = {{zero, zero}, zero, Eigen::Vector2d(0, 0)};
  w[1] = {{zero, one}, one, Eigen::Vector2d(0.1, 0)};
  w[2] = {{one, one}, zero, Eigen::Vector2d(5, 0)};
  const PredictionMetrics m = evaluate_predictions(w, 0.5);
  EXPECT_EQ(m.num_windows, 3);
  EXPECT_NEAR(m.apd_m, std::sqrt(6.0) / 3, 1e-12);           // only window 1 is diverse: ||one|| = sqrt 6
  EXPECT_NEAR(m.ade_m, std::sqrt(2.0) / 3, 1e-12);           // windows 0, 1: exact; 2: sqrt 2
  EXPECT_NEAR(m.fde_m, std::sqrt(2.0) / 3, 1e-12);
  // Window 0 vs {zero, one}: (0 + sqrt 2) / 2; window 1: (0 + 0) / 2; window 2 vs {zero}: sqrt 2.
  EXPECT_NEAR(m.mmade_m, (std::sqrt(2.0) / 2 + std::sqrt(2.0)) / 3, 1e-12);
  EXPECT_NEAR(m.mmfde_m, (std::sqrt(2.0) / 2 + std::sqrt(2.0)) / 3, 1e-12);
  EXPECT_THROW(evaluate_predictions({}, 0.5), Error);
}

TEST(PredictionTest, MultimodalGroundTruthByLastContextPose) {
  Eigen::MatrixXd c(3, 2);
  c << 0, 0, 0.3, 0.4, 3, 0;
  const auto groups = multimodal_ground_truth(c, 0.5);
  EXPECT_EQ(groups[0], (std::vector<int>{0, 1}));
  EXPECT_EQ(groups[1], (std::vector<int>{0, 1}));
  EXPECT_EQ(groups[2], (std::vector<int>{2}));
}

TEST(PredictionTest, SpectralEntropyOfToneAndImpulse) {
  const int n = 16;
  Eigen::MatrixXd tone(n, 1), impulse = Eigen::MatrixXd::Zero(n, 1);
  for (int t = 0; t < n; ++t) tone(t, 0) = std::cos(2 * M_PI * 2 * t / n);
  impulse(0, 0) = 1;
  EXPECT_NEAR(spectral_entropy(tone), 0.0, 1e-9);
  EXPECT_NEAR(spectral_entropy(impulse), std::log(8.0), 1e-12);  // flat over k = 1..8
  EXPECT_NEAR(spectral_entropy_difference({impulse}, {tone}), std::log(8.0), 1e-9);
  Eigen::MatrixXd odd = Eigen::MatrixXd::Zero(15, 1);  // odd length: k = 1..7, still flat
  odd(4, 0) = 2.5;
  EXPECT_NEAR(spectral_entropy(odd), std::log(7.0), 1e-12);
  // Constant columns carry no spectrum and are skipped.
  Eigen::MatrixXd both(n, 2);
  both << impulse, Eigen::VectorXd::Constant(n, 5.0);
  EXPECT_NEAR(spectral_entropy(both), std::log(8.0), 1e-12);
}

TEST(DistributionTest, MeanPoseDistance) {
  Eigen::MatrixXd a(1, 1), b(1, 1), c(1, 1);
  a << 0;
  b << 0;
  c << 3;
  const MeanPoseDistance d = mean_pose_distance({a, b, c});  // mean 1: distances 1, 1, 2
  EXPECT_NEAR(d.mean_m[0], 4.0 / 3, 1e-12);
  EXPECT_NEAR(d.std_m[0], std::sqrt(2.0 / 9), 1e-12);
}

TEST(RecognisabilityTest, InceptionScore) {
  Eigen::MatrixXd confident = Eigen::MatrixXd::Zero(6, 3);
  for (int i = 0; i < 6; ++i) confident(i, i % 3) = 1;
  EXPECT_NEAR(inception_score(confident), 3.0, 1e-12);
  const Eigen::MatrixXd same = Eigen::MatrixXd::Constant(4, 3, 1.0 / 3);
  EXPECT_NEAR(inception_score(same), 1.0, 1e-12);
}

TEST(RecognisabilityTest, FidOfIdenticalAndShiftedSets) {
  Eigen::MatrixXd base(4, 2);
  base << -1, 0, 1, 0, 0, -1, 0, 1;  // mean 0, unbiased covariance (2/3) I
  EXPECT_NEAR(frechet_inception_distance(base, base), 0.0, 1e-12);
  const Eigen::RowVector2d shift(3, 4);
  const Eigen::MatrixXd shifted = base.rowwise() + shift;
  EXPECT_NEAR(frechet_inception_distance(base, shifted), 25.0, 1e-9);
  // Scaled by 2: covariance (8/3) I; per dimension (sqrt(2/3) - sqrt(8/3))^2 = 2/3.
  const Eigen::MatrixXd scaled = (2 * base).rowwise() + shift;
  EXPECT_NEAR(frechet_inception_distance(base, scaled), 25.0 + 4.0 / 3, 1e-9);
  // Non-commuting covariances: closed form in 1D per axis after a common rotation is not
  // available, so check symmetry and a random set against itself.
  const Eigen::MatrixXd r = Eigen::MatrixXd::Random(50, 5), s = Eigen::MatrixXd::Random(40, 5) * 2;
  EXPECT_NEAR(frechet_inception_distance(r, s), frechet_inception_distance(s, r), 1e-9);
  EXPECT_NEAR(frechet_inception_distance(r, r), 0.0, 1e-9);
}

TEST(SetMetricsTest, SyntheticWalks) {
  Clip c{make_synthetic_biped(), {}};
  std::vector<MotionPositions> motions;
  for (int i = 0; i < 2; ++i) {
    SyntheticWalkOptions o;
    o.start_heading_rad = 0.5 * i;
    c.motion = make_synthetic_walk(c.skeleton, 60, 30.0, o);
    motions.push_back(motion_positions(c));
  }
  const auto rows = set_metrics(motions);
  const nlohmann::json j = metrics_to_json(rows);
  EXPECT_EQ(j["motions"].get<double>(), 2);
  EXPECT_EQ(j["frames"].get<double>(), 120);
  EXPECT_LT(j["bone_length_rmse_cm"].get<double>(), 1e-6);
  EXPECT_GT(j["apd_m"].get<double>(), 0.0);
  EXPECT_GT(j["footsteps.max_steps"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(j["pelvis_ground_speed_mps"].get<double>(), pelvis_ground_speed_mps(motions));
  EXPECT_GT(j["pelvis_ground_speed_mps"].get<double>(), 0.3);  // the synthetic walk moves
  // One motion: no diversity.
  EXPECT_TRUE(metrics_to_json(set_metrics({motions[0]}))["apd_m"].is_null());
}

}  // namespace
}  // namespace mosyn::eval
