// Control signals: paths walked at the requested speed, clip root motion re-integrated exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <unistd.h>

#include "core/error.h"
#include "core/synthetic.h"
#include "core/trajectory.h"
#include "data/control.h"
#include "io/csv.h"

namespace mosyn::data {
namespace {

TEST(ControlTest, ParsePathAcceptsPointsAndPauses) {
  const auto path = parse_path(" 0,0,2 3,0;3,4 ");
  ASSERT_EQ(path.size(), 3u);
  EXPECT_DOUBLE_EQ(path[0].pause_s, 2.0);
  EXPECT_DOUBLE_EQ(path[2].x_m, 3.0);
  EXPECT_DOUBLE_EQ(path[2].z_m, 4.0);
}

TEST(ControlTest, ParsePathRejectsGarbage) {
  EXPECT_THROW(parse_path(""), Error);
  EXPECT_THROW(parse_path("1"), Error);
  EXPECT_THROW(parse_path("1,2,3,4"), Error);
  EXPECT_THROW(parse_path("1,x"), Error);
  EXPECT_THROW(parse_path("1,nan"), Error);
  EXPECT_THROW(parse_path("0,0,-1"), Error);
}

// Regression (fuzz/corpus/csv/crash-path-1000km.txt): a path without a duration lasts as long as
// walking it takes, which must stay within the 3600 s an explicit duration may have, instead of
// allocating a control of millions of frames.
TEST(ControlTest, OverlongOrInfinitePathsAreRefused) {
  PathOptions options;  // seconds = 0: as long as the path takes
  EXPECT_THROW(control_from_path(parse_path("0,0 0,999999 2,20"), options), Error);
  EXPECT_THROW(control_from_path(parse_path("0,0,1e300 1,1"), options), Error);
  options.seconds = 5;  // an explicit duration cuts the walk off
  EXPECT_EQ(control_from_path(parse_path("0,0 0,999999"), options).size(), 3u * (5 * 30 + 1));
  options.seconds = 0;
  EXPECT_NO_THROW(control_from_path(parse_path("0,0 0,1000"), options));  // about 13 minutes
}

TEST(ControlTest, StraightPathEndsAtTheLastWaypoint) {
  PathOptions options;
  options.speed_mps = 1.5;
  double heading = 0;
  const auto control = control_from_path(parse_path("0,0 0,6"), options, &heading);
  EXPECT_NEAR(heading, 0.0, 1e-9);  // facing +Z
  const auto ground = integrate_control(control, heading);
  EXPECT_NEAR(ground.back().x(), 0.0, 1e-3);
  EXPECT_NEAR(ground.back().z(), 6.0, 1e-3);
  // Cruising speed reaches the requested speed; no sideways motion on a straight line.
  double max_speed = 0;
  for (size_t t = 1; t < control.size() / 3; ++t) {
    max_speed = std::max(max_speed, std::hypot(control[3 * t], control[3 * t + 1]) * options.fps);
    EXPECT_NEAR(control[3 * t], 0.0, 1e-6);
  }
  EXPECT_NEAR(max_speed, 1.5, 1e-3);
  // Duration: length / speed + ramp time + one second standing.
  EXPECT_NEAR((control.size() / 3 - 1) / options.fps, 6.0 / 1.5 + options.accel_s + 1.0, 2.0 / options.fps);
}

TEST(ControlTest, CornersTurnByTheCornerAngle) {
  PathOptions options;
  double heading = 0;
  const auto control = control_from_path(parse_path("0,0 0,4 4,4"), options, &heading);
  double total_turn = 0;
  for (size_t t = 1; t < control.size() / 3; ++t) total_turn += control[3 * t + 2];
  // From facing +Z to facing +X is +90 degrees about +Y: a left turn (the character's left is +X).
  EXPECT_NEAR(total_turn, M_PI / 2, 1e-3);
  const auto ground = integrate_control(control, heading);
  EXPECT_NEAR(ground.back().x(), 4.0, 1e-3);
  EXPECT_NEAR(ground.back().z(), 4.0, 1e-3);
}

TEST(ControlTest, SingleWaypointStandsStill) {
  PathOptions options;
  options.seconds = 3;
  const auto control = control_from_path(parse_path("1,1"), options);
  EXPECT_EQ(control.size() / 3, 91u);
  for (float v : control) EXPECT_EQ(v, 0.0f);
}

TEST(ControlTest, PauseAtStartStandsThenWalks) {
  PathOptions options;
  const auto control = control_from_path(parse_path("0,0,2 0,3"), options);
  for (int t = 0; t <= 59; ++t) EXPECT_EQ(control[3 * t + 1], 0.0f) << t;  // 2 s standing
  double moved = 0;
  for (size_t t = 61; t < control.size() / 3; ++t) moved += control[3 * t + 1];
  EXPECT_NEAR(moved, 3.0, 1e-3);
}

// A synthetic biped walking `frames` frames at 30 fps, turning at turn_rate_rad_s.
Clip turning_walk(int frames, double turn_rate_rad_s) {
  Clip clip;
  clip.skeleton = make_synthetic_biped();
  SyntheticWalkOptions walk;
  walk.turn_rate_rad_s = turn_rate_rad_s;
  clip.motion = make_synthetic_walk(clip.skeleton, frames, 30.0, walk);
  return clip;
}

TEST(ControlTest, ClipControlReintegratesToTheRootPath) {
  const Clip clip = turning_walk(120, 0.4);
  double heading = 0;
  const auto control = control_from_clip(clip, 30.0, &heading);
  ASSERT_EQ(control.size(), 3u * 120);
  const auto ground =
      ground_trajectory(clip.skeleton, clip.motion, 0, estimate_forward_in_root(clip.skeleton));
  const auto path = integrate_control(control, heading);
  const double mpu = clip.skeleton.meters_per_unit;
  for (int t = 0; t < 120; ++t) {
    const Eigen::Vector3d expected = (ground.positions[t] - ground.positions[0]) * mpu;
    EXPECT_NEAR(path[t].x(), expected.x(), 1e-5) << t;
    EXPECT_NEAR(path[t].z(), expected.z(), 1e-5) << t;
  }
}

// The control of a turning walk at 30 fps, resampled to 20 fps, traces the same path: at the times
// both grids share (every 0.1 s) the re-integrated positions and headings agree; per frame the
// steps are 1.5 times as long, so the speed in m/s is the same.
TEST(ControlTest, ResampledControlTracesTheSamePathInTheSameTime) {
  const std::vector<float> at30 = control_from_clip(turning_walk(91, 0.6), 30.0);
  std::vector<double> times30;
  for (int t = 0; t < 91; ++t) times30.push_back(t / 30.0);
  const std::vector<float> at20 = resample_control(at30, times30, 20.0);
  ASSERT_EQ(at20.size(), 3u * 61);  // 3 s at 20 fps, both ends included
  std::vector<double> h30, h20;
  const auto p30 = integrate_control(at30, 0.0, &h30), p20 = integrate_control(at20, 0.0, &h20);
  for (int k = 0; k <= 30; ++k) {
    EXPECT_LT((p20[2 * k] - p30[3 * k]).norm(), 1e-5) << k;
    EXPECT_NEAR(h20[2 * k], h30[3 * k], 1e-6) << k;
  }
  double forward30 = 0, forward20 = 0;
  for (int t = 1; t < 91; ++t) forward30 += at30[3 * t + 1];
  for (int t = 1; t < 61; ++t) forward20 += at20[3 * t + 1];
  EXPECT_NEAR(forward20 / 60, 1.5 * forward30 / 90, 0.02 * forward30 / 90);
  // The same times and rate give the control back.
  const std::vector<float> again = resample_control(at30, times30, 30.0);
  ASSERT_EQ(again.size(), at30.size());
  for (size_t i = 0; i < at30.size(); ++i) EXPECT_NEAR(again[i], at30[i], 1e-6) << i;
  EXPECT_THROW(resample_control(at30, {0.0, 1.0}, 20.0), Error);
  std::vector<double> stalled = times30;
  stalled[5] = stalled[4];
  EXPECT_THROW(resample_control(at30, stalled, 20.0), Error);
  EXPECT_THROW(resample_control(at30, times30, 0.0), Error);
}

// A CSV control is read at the model's rate: by its t_s column, by the rate given for a file
// without one, or as frames at the model's rate when neither is known.
TEST(ControlTest, CsvControlIsResampledByItsTimesOrGivenRate) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mosyn_control_csv_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::vector<Eigen::Vector3d> rows;
  for (int t = 0; t < 31; ++t) rows.emplace_back(0.0, t > 0 ? 0.04 : 0.0, t > 0 ? 0.01 : 0.0);  // 1.2 m/s at 30 fps
  const std::string timed = (dir / "timed.csv").string(), plain = (dir / "plain.csv").string();
  io::write_control_csv(timed, rows, 30.0);
  io::write_control_csv(plain, rows);
  const std::vector<float> from_times = control_from_csv(timed, 20.0);
  ASSERT_EQ(from_times.size(), 3u * 21);
  const std::vector<float> from_rate = control_from_csv(plain, 20.0, 30.0);
  ASSERT_EQ(from_rate.size(), from_times.size());
  for (size_t i = 0; i < from_rate.size(); ++i) EXPECT_NEAR(from_rate[i], from_times[i], 1e-6) << i;
  EXPECT_NEAR(integrate_control(from_times).back().norm(), integrate_control(control_from_csv(plain, 30.0)).back().norm(),
              1e-5);
  const std::vector<float> as_is = control_from_csv(plain, 20.0);  // no rate known: frames at 20 fps
  ASSERT_EQ(as_is.size(), 3u * 31);
  EXPECT_FLOAT_EQ(as_is[3 * 5 + 1], 0.04f);
  EXPECT_THROW(control_from_csv(timed, 20.0, 30.0), Error);  // times and a rate: which one?
  EXPECT_THROW(control_from_csv(plain, 0.0), Error);
  std::filesystem::remove_all(dir);
}

}  // namespace
// A user's path re-shaped like the smoothed training controls: it starts and ends where it did,
// turns less abruptly at a corner, and still stands still once stopped.
TEST(ControlTest, SmoothControlKeepsThePathEndsAndSoftensCorners) {
  PathOptions o;
  o.fps = 20;
  o.corner_radius_m = 0.0;  // a sharp corner
  o.accel_s = 0.0;          // and a sudden start and stop
  double heading = 0;
  const std::vector<float> raw = control_from_path(parse_path("0,0 0,3 3,3"), o, &heading);
  const std::vector<float> smooth = smooth_control(raw, o.fps, 0.35);
  ASSERT_EQ(smooth.size(), raw.size());
  const auto a = integrate_control(raw, heading), b = integrate_control(smooth, heading);
  EXPECT_LT((a.back() - b.back()).norm(), 1e-4);
  EXPECT_EQ(smooth[0], 0.0f);
  auto max_abs = [](const std::vector<float>& c, int k) {
    double m = 0;
    for (size_t t = 0; t < c.size() / 3; ++t) m = std::max(m, std::abs(static_cast<double>(c[3 * t + k])));
    return m;
  };
  EXPECT_LT(max_abs(smooth, 2), 0.5 * max_abs(raw, 2));
  // The last frames stand still (the path ends with a second of standing).
  for (size_t t = smooth.size() / 3 - 3; t < smooth.size() / 3; ++t) EXPECT_NEAR(smooth[3 * t + 1], 0.0, 1e-3);
  EXPECT_EQ(smooth_control(raw, o.fps, 0.0), raw);
  EXPECT_THROW(smooth_control({1.0f, 2.0f}, 20, 0.35), Error);
}

}  // namespace mosyn::data
