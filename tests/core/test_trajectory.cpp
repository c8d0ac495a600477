#include "core/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/rotation.h"
#include "core/synthetic.h"
#include "test_bvh_reader.h"

namespace mosyn {
namespace {

constexpr double kPi = 3.14159265358979323846;

double wrap(double a) { return std::remainder(a, 2 * kPi); }

// The same character re-expressed with up axis `up`: the whole scene is rotated by the cyclic
// permutation that takes Y to `up` (Y-up's forward Z and sideways X go to the new convention's
// forward and sideways axes), joint frames included.
Eigen::Quaterniond up_permutation(int up) {
  Eigen::Matrix3d p = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) p((i + up - 1 + 3) % 3, i) = 1;  // e_i -> e_{i + up - 1}
  return Eigen::Quaterniond(p);
}

void rotate_scene(Skeleton& s, Motion& m, const Eigen::Quaterniond& q, int up) {
  s.up_axis = up;
  for (auto& o : s.offsets) o = q * o;
  for (auto& e : s.end_sites) e.offset = q * e.offset;
  for (auto& t : m.translations) t = q * t;
  for (auto& r : m.rotations) r = q * r * q.conjugate();
}

TEST(Trajectory, HeadingConventionYUp) {
  const Skeleton s = make_synthetic_biped();
  for (double theta : {-3.0, -1.0, 0.0, 0.4, 2.5}) {
    const Eigen::Vector3d facing(std::sin(theta), 0, std::cos(theta));
    EXPECT_NEAR(heading_of(s, facing), theta, 1e-12);
    EXPECT_NEAR(heading_of(s, facing * 3 + Eigen::Vector3d(0, 5, 0)), theta, 1e-12);  // up part ignored
    EXPECT_LT((heading_rotation(s, theta) * Eigen::Vector3d::UnitZ() - facing).norm(), 1e-12);
  }
  EXPECT_NEAR(heading_of(s, Eigen::Vector3d::UnitX()), kPi / 2, 1e-15);
}

TEST(Trajectory, HeadingConventionOtherUpAxes) {
  Skeleton s = make_synthetic_biped();
  for (int up = 0; up < 3; ++up) {
    s.up_axis = up;
    const Eigen::Quaterniond q = up_permutation(up);
    EXPECT_LT((q * Eigen::Vector3d::UnitY() - Eigen::Vector3d::Unit(up)).norm(), 1e-15);
    for (double theta : {-2.0, 0.3, 1.9}) {
      const Eigen::Vector3d facing = q * Eigen::Vector3d(std::sin(theta), 0, std::cos(theta));
      EXPECT_NEAR(heading_of(s, facing), theta, 1e-12);
      EXPECT_LT((heading_rotation(s, theta) * (q * Eigen::Vector3d::UnitZ()) - facing).norm(), 1e-12);
    }
  }
}

TEST(Trajectory, DeltasByHand) {
  const Skeleton s = make_synthetic_biped();
  GroundTrajectory g;
  g.positions = {{0, 0, 0}, {1, 0, 0}, {1, 0, 2}};
  g.headings_rad = {0.0, kPi / 2, kPi / 2 + 0.25};
  const auto d = root_deltas(s, g);
  ASSERT_EQ(d.size(), 3u);
  EXPECT_EQ(d[0].forward, 0);
  EXPECT_EQ(d[0].sideways, 0);
  EXPECT_EQ(d[0].turn_rad, 0);
  // Facing +Z, moving +X: one unit sideways (the sideways axis is +X at heading 0).
  EXPECT_NEAR(d[1].sideways, 1, 1e-15);
  EXPECT_NEAR(d[1].forward, 0, 1e-15);
  EXPECT_NEAR(d[1].turn_rad, kPi / 2, 1e-15);
  // Facing +X, moving +Z: sideways axis is now -Z, so two units to the right.
  EXPECT_NEAR(d[2].forward, 0, 1e-15);
  EXPECT_NEAR(d[2].sideways, -2, 1e-15);
  EXPECT_NEAR(d[2].turn_rad, 0.25, 1e-15);
}

TEST(Trajectory, ForwardOfSyntheticBipedIsPlusZAndRotatesWithTheRestPose) {
  const Skeleton s = make_synthetic_biped();
  EXPECT_LT((estimate_forward_in_root(s) - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  // A rest pose lying in any orientation (Bandai-Namco's lies along +X) keeps the facing
  // attached to the body.
  std::mt19937 rng(4);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized();
    Skeleton r = s;
    for (auto& o : r.offsets) o = q * o;
    EXPECT_LT((estimate_forward_in_root(r) - q * Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  }
}

TEST(Trajectory, ForwardFallsBackWithoutPairs) {
  Skeleton s;
  s.joint_names = {"root", "a"};
  s.parents = {-1, 0};
  s.offsets = {{0, 0, 0}, {0, 1, 0}};
  EXPECT_EQ(estimate_forward_in_root(s), Eigen::Vector3d::UnitZ());
  s.up_axis = 2;
  EXPECT_EQ(estimate_forward_in_root(s), Eigen::Vector3d::UnitX());
}

TEST(Trajectory, ForwardFollowsHipPairSittingOnTheRoot) {
  // CMU-like: LHipJoint/RHipJoint coincide with Hips, the legs start one joint further.
  Skeleton s;
  s.joint_names = {"Hips", "LHipJoint", "LeftUpLeg", "RHipJoint", "RightUpLeg", "LowerBack", "Spine"};
  s.parents = {-1, 0, 1, 0, 3, 0, 5};
  s.offsets = {{0, 10, 0}, {0, 0, 0}, {1, -1, 0}, {0, 0, 0}, {-1, -1, 0}, {0, 0, 0}, {0, 2, 0}};
  EXPECT_LT((estimate_forward_in_root(s) - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(Trajectory, RoundTripExactOnLongTurningWalks) {
  const Skeleton s = make_synthetic_biped();
  const Eigen::Vector3d forward = estimate_forward_in_root(s);
  for (double turn : {1.3, -0.9, 0.0}) {
    SyntheticWalkOptions o;
    o.turn_rate_rad_s = turn;
    o.start_heading_rad = 3.0;  // close to pi: wraps immediately when turning left
    o.noise_rad = 0.02;
    o.seed = 9;
    const int frames = 900;  // 30 s: 39 rad of turning, six full circles
    const Motion m = make_synthetic_walk(s, frames, 30, o);
    const GroundTrajectory g = ground_trajectory(s, m, 0, forward);
    ASSERT_EQ(g.positions.size(), static_cast<size_t>(frames));
    for (int t = 1; t < frames; ++t) {
      EXPECT_LT(std::abs(g.headings_rad[t] - g.headings_rad[t - 1]), 0.5) << "heading jumps at " << t;
      EXPECT_EQ(g.positions[t].y(), 0.0);
    }
    // Unwrapped: the final heading is the start plus the whole turn (up to the sway).
    EXPECT_NEAR(g.headings_rad.back(), 3.0 + turn * (frames - 1) / 30.0, 0.2);

    const std::vector<RootDelta> d = root_deltas(s, g);
    const GroundTrajectory back = integrate_root_deltas(s, d, g.positions[0], g.headings_rad[0]);
    ASSERT_EQ(back.positions.size(), g.positions.size());
    for (int t = 0; t < frames; ++t) {
      EXPECT_LT((back.positions[t] - g.positions[t]).norm(), 1e-9) << t;
      EXPECT_NEAR(back.headings_rad[t], g.headings_rad[t], 1e-9) << t;
    }
    // Walking forward at 1.3 m/s on its own heading: forward delta 130 cm / 30 frames.
    double forward_sum = 0, sideways_sum = 0, turn_sum = 0;
    for (int t = 1; t < frames; ++t) {
      forward_sum += d[t].forward;
      sideways_sum += d[t].sideways;
      turn_sum += d[t].turn_rad;
    }
    EXPECT_NEAR(forward_sum / (frames - 1), 130.0 / 30, 0.05);
    // On an arc the chord of one frame turns by half the frame's turn from the previous heading.
    EXPECT_NEAR(sideways_sum / (frames - 1), 130.0 / 30 * std::sin(turn / 60), 0.02);
    EXPECT_NEAR(turn_sum / (frames - 1), turn / 30, 1e-3);
  }
}

TEST(Trajectory, HeadingFollowsVelocityOnStraightWalk) {
  const Skeleton s = make_synthetic_biped();
  for (double start : {-2.8, -0.7, 0.0, 1.2, 3.1}) {
    SyntheticWalkOptions o;
    o.start_heading_rad = start;
    const Motion m = make_synthetic_walk(s, 120, 30, o);
    const GroundTrajectory g = ground_trajectory(s, m, 0, estimate_forward_in_root(s));
    for (int t = 1; t < m.num_frames; ++t) {
      const Eigen::Vector3d v = g.positions[t] - g.positions[t - 1];
      const double velocity_heading = heading_of(s, v);
      EXPECT_NEAR(velocity_heading, start, 1e-9);  // straight path
      EXPECT_LT(std::abs(wrap(g.headings_rad[t] - velocity_heading)), 0.1) << "start " << start << " frame " << t;
    }
  }
}

TEST(Trajectory, SameTrajectoryForEveryUpAxis) {
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = 0.8;
  const Motion m = make_synthetic_walk(s, 200, 30, o);
  const GroundTrajectory ref = ground_trajectory(s, m, 0, estimate_forward_in_root(s));
  for (int up = 0; up < 3; ++up) {
    Skeleton su = s;
    Motion mu = m;
    const Eigen::Quaterniond q = up_permutation(up);
    rotate_scene(su, mu, q, up);
    const GroundTrajectory g = ground_trajectory(su, mu, 0, estimate_forward_in_root(su));
    const auto d_ref = root_deltas(s, ref), d = root_deltas(su, g);
    for (int t = 0; t < m.num_frames; ++t) {
      EXPECT_NEAR(g.headings_rad[t], ref.headings_rad[t], 1e-9);
      EXPECT_LT((g.positions[t] - q * ref.positions[t]).norm(), 1e-9);
      EXPECT_NEAR(d[t].forward, d_ref[t].forward, 1e-9);
      EXPECT_NEAR(d[t].sideways, d_ref[t].sideways, 1e-9);
    }
  }
}

TEST(Trajectory, NonRootJointUnderStaticRoot) {
  // Bandai-Namco layout: a static joint_Root above the joint that carries the motion.
  const Skeleton s = make_synthetic_biped();
  SyntheticWalkOptions o;
  o.turn_rate_rad_s = -0.6;
  const Motion m = make_synthetic_walk(s, 90, 30, o);
  Skeleton b;
  b.joint_names.push_back("joint_Root");
  b.parents.push_back(-1);
  b.offsets.emplace_back(0, 0, 0);
  for (int j = 0; j < s.num_joints(); ++j) {
    b.joint_names.push_back(s.joint_names[j]);
    b.parents.push_back(s.parents[j] + 1);
    b.offsets.push_back(s.offsets[j]);
  }
  Motion mb = Motion::rest(b, m.num_frames, m.fps);
  for (int t = 0; t < m.num_frames; ++t)
    for (int j = 0; j < s.num_joints(); ++j) {
      mb.rotation(t, j + 1) = m.rotation(t, j);
      mb.translation(t, j + 1) = m.translation(t, j);
    }
  const Eigen::Vector3d f = estimate_forward_in_root(b);
  EXPECT_LT((f - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  const GroundTrajectory ref = ground_trajectory(s, m, 0, f), g = ground_trajectory(b, mb, 1, f);
  for (int t = 0; t < m.num_frames; ++t) {
    EXPECT_LT((g.positions[t] - ref.positions[t]).norm(), 1e-12);
    EXPECT_NEAR(g.headings_rad[t], ref.headings_rad[t], 1e-12);
  }
  EXPECT_THROW(ground_trajectory(b, mb, 99, f), Error);
}

// --- Real data: the sign conventions hold on both datasets. ---

struct WalkStats {
  double mean_forward_per_s = 0;   // skeleton units per second along the heading
  double mean_sideways_per_s = 0;
  double mean_abs_heading_error_rad = 0;  // heading vs. direction of travel (1 s window)
};

WalkStats walk_stats(const Clip& clip, int root_joint, int first_frame) {
  const Skeleton& s = clip.skeleton;
  const GroundTrajectory g = ground_trajectory(s, clip.motion, root_joint, estimate_forward_in_root(s));
  const auto d = root_deltas(s, g);
  WalkStats out;
  const int frames = clip.motion.num_frames;
  const double fps = clip.motion.fps;
  for (int t = first_frame + 1; t < frames; ++t) {
    out.mean_forward_per_s += d[t].forward * fps;
    out.mean_sideways_per_s += d[t].sideways * fps;
  }
  out.mean_forward_per_s /= frames - first_frame - 1;
  out.mean_sideways_per_s /= frames - first_frame - 1;
  const int half = static_cast<int>(fps / 2);
  int count = 0;
  for (int t = first_frame + half; t + half < frames; ++t) {
    const Eigen::Vector3d v = g.positions[t + half] - g.positions[t - half];
    out.mean_abs_heading_error_rad += std::abs(wrap(g.headings_rad[t] - heading_of(s, v)));
    ++count;
  }
  out.mean_abs_heading_error_rad /= std::max(count, 1);
  return out;
}

TEST(Trajectory, RealDataBandaiWalkGoesForward) {
  const std::string path = testing::data_file(
      "bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk_normal_001.bvh");
  if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
  const Clip clip = testing::read_bvh_for_tests(path);
  const int hips = clip.skeleton.find("Hips");
  ASSERT_EQ(hips, 1);
  // The rest pose lies along +X, legs' left along -Y: the facing is +Z in Hips' frame.
  const Eigen::Vector3d f = estimate_forward_in_root(clip.skeleton);
  EXPECT_GT(f.z(), 0.99) << f.transpose();
  const WalkStats w = walk_stats(clip, hips, 0);
  EXPECT_GT(w.mean_forward_per_s, 80.0);  // cm/s
  EXPECT_LT(std::abs(w.mean_sideways_per_s), 0.2 * w.mean_forward_per_s);
  EXPECT_LT(w.mean_abs_heading_error_rad, 0.2);
}

TEST(Trajectory, RealDataBandaiWalkBackGoesBackward) {
  const std::string path = testing::data_file(
      "bandai-namco/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk-back_normal_001.bvh");
  if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
  const Clip clip = testing::read_bvh_for_tests(path);
  const WalkStats w = walk_stats(clip, clip.skeleton.find("Hips"), 0);
  EXPECT_LT(w.mean_forward_per_s, -30.0);
}

// Independent check of the hip-based heading: the facing of the shoulder line, (left - right) x up,
// in world space (mean absolute difference; sign or axis mistakes would give pi/2 or pi).
double mean_shoulder_disagreement(const Clip& clip, int root_joint, const char* left, const char* right) {
  const Skeleton& s = clip.skeleton;
  const GroundTrajectory g = ground_trajectory(s, clip.motion, root_joint, estimate_forward_in_root(s));
  const WorldPoses w = forward_kinematics(s, clip.motion);
  const int l = s.find(left), r = s.find(right);
  double sum = 0;
  for (int t = 0; t < clip.motion.num_frames; ++t) {
    const Eigen::Vector3d across = w.position(t, l) - w.position(t, r);
    sum += std::abs(wrap(g.headings_rad[t] - heading_of(s, across.cross(Eigen::Vector3d::UnitY()))));
  }
  return sum / clip.motion.num_frames;
}

TEST(Trajectory, RealDataHeadingAgreesWithShoulderLine) {
  // Bandai's walk-left/right clips walk forward towards the left/right of the room: the whole
  // body faces the direction of travel (+X), which both estimates must agree on.
  for (const char* file : {"Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk-left_normal_001.bvh",
                           "Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk-right_normal_001.bvh",
                           "Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk-turn-right_normal_001.bvh",
                           "Bandai-Namco-Research-Motiondataset-2/data/dataset-2_run_normal_001.bvh"}) {
    const std::string path = testing::data_file(std::string("bandai-namco/") + file);
    if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
    const Clip clip = testing::read_bvh_for_tests(path);
    EXPECT_LT(mean_shoulder_disagreement(clip, 1, "Shoulder_L", "Shoulder_R"), 0.4) << file;
    const WalkStats w = walk_stats(clip, 1, 0);
    EXPECT_GT(w.mean_forward_per_s, 50.0) << file;
    EXPECT_LT(w.mean_abs_heading_error_rad, 0.3) << file;
  }
  const std::string cmu = testing::data_file("cmu-mocap-subset/bvh/02/02_01.bvh");
  if (cmu.empty()) GTEST_SKIP() << "CMU data not unpacked";
  EXPECT_LT(mean_shoulder_disagreement(testing::read_bvh_for_tests(cmu), 0, "LeftArm", "RightArm"), 0.4);
}

TEST(Trajectory, RealDataBandaiTurnLeftTurnsCounterClockwise) {
  const std::string path = testing::data_file(
      "bandai-namco/Bandai-Namco-Research-Motiondataset-2/data/dataset-2_walk-turn-left_normal_001.bvh");
  if (path.empty()) GTEST_SKIP() << "Bandai-Namco data not unpacked";
  const Clip clip = testing::read_bvh_for_tests(path);
  const GroundTrajectory g = ground_trajectory(clip.skeleton, clip.motion, clip.skeleton.find("Hips"),
                                               estimate_forward_in_root(clip.skeleton));
  // Turning left = counter-clockwise seen from above = increasing heading about +Y.
  EXPECT_GT(g.headings_rad.back() - g.headings_rad.front(), 0.5);
}

TEST(Trajectory, RealDataCmuWalkGoesForward) {
  for (const char* file : {"bvh/02/02_01.bvh", "bvh/07/07_01.bvh", "bvh/05/05_01.bvh"}) {
    const std::string path = testing::data_file(std::string("cmu-mocap-subset/") + file);
    if (path.empty()) GTEST_SKIP() << "CMU data not unpacked";
    const Clip clip = testing::read_bvh_for_tests(path);
    const Eigen::Vector3d f = estimate_forward_in_root(clip.skeleton);
    EXPECT_GT(f.z(), 0.95) << file << ": " << f.transpose();
    const WalkStats w = walk_stats(clip, 0, 1);  // frame 0 is the converter's T-pose
    EXPECT_GT(w.mean_forward_per_s, 10.0) << file;  // CMU units (5.6 cm) per second
    EXPECT_LT(std::abs(w.mean_sideways_per_s), 0.2 * w.mean_forward_per_s) << file;
    EXPECT_LT(w.mean_abs_heading_error_rad, 0.2) << file;
  }
}

}  // namespace
// Gaussian smoothing against a brute-force convolution of the point-reflected signal.
TEST(Trajectory, SmoothingMatchesBruteForceConvolution) {
  GroundTrajectory g;
  const int n = 50;
  for (int t = 0; t < n; ++t) {
    g.positions.emplace_back(0.3 * t + 0.05 * std::sin(2.0 * t), 0.0, 0.1 * t * t / n);
    g.headings_rad.push_back(0.02 * t + 0.1 * std::cos(1.3 * t));
  }
  const double sigma = 3.0;
  const GroundTrajectory s = smooth_ground_trajectory(g, sigma);
  ASSERT_EQ(s.positions.size(), g.positions.size());
  auto reflected = [&](const std::vector<double>& x, int i) {
    if (i < 0) return 2 * x[0] - x[-i];
    if (i >= n) return 2 * x[n - 1] - x[2 * (n - 1) - i];
    return x[i];
  };
  std::vector<double> px, pz;
  for (const auto& p : g.positions) {
    px.push_back(p.x());
    pz.push_back(p.z());
  }
  const int radius = 12;
  for (int t = 0; t < n; ++t) {
    double wsum = 0, x = 0, z = 0, h = 0;
    for (int k = -radius; k <= radius; ++k) {
      const double w = std::exp(-0.5 * k * k / (sigma * sigma));
      wsum += w;
      x += w * reflected(px, t + k);
      z += w * reflected(pz, t + k);
      h += w * reflected(g.headings_rad, t + k);
    }
    EXPECT_NEAR(s.positions[t].x(), x / wsum, 1e-12);
    EXPECT_NEAR(s.positions[t].z(), z / wsum, 1e-12);
    EXPECT_EQ(s.positions[t].y(), 0.0);
    EXPECT_NEAR(s.headings_rad[t], h / wsum, 1e-12);
  }
  // Point reflection keeps the ends exactly and a straight line unchanged.
  EXPECT_NEAR((s.positions.front() - g.positions.front()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((s.positions.back() - g.positions.back()).norm(), 0.0, 1e-12);
  GroundTrajectory line;
  for (int t = 0; t < 20; ++t) {
    line.positions.emplace_back(0.04 * t, 0.0, -0.02 * t);
    line.headings_rad.push_back(0.01 * t);
  }
  const GroundTrajectory same = smooth_ground_trajectory(line, 4.0);
  for (int t = 0; t < 20; ++t) {
    EXPECT_NEAR((same.positions[t] - line.positions[t]).norm(), 0.0, 1e-12);
    EXPECT_NEAR(same.headings_rad[t], line.headings_rad[t], 1e-12);
  }
  EXPECT_THROW(smooth_ground_trajectory(g, 1e5), Error);
  EXPECT_EQ(smooth_ground_trajectory(g, 0.0).positions[3], g.positions[3]);
}

}  // namespace mosyn
