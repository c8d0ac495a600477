// data::RootController: the filters against their closed form and a fine Euler integration, the
// prediction against stepping, and the stick's world velocity and facing reached.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/trajectory.h"
#include "data/root_controller.h"

namespace mosyn::data {
namespace {

RootControllerOptions options(double fps, double smoothing_s) {
  RootControllerOptions o;
  o.fps = fps;
  o.smoothing_s = smoothing_s;
  return o;
}

// x'' = w^2 (u - x) - 2 w x' from rest, integrated with 1000 Euler substeps per frame.
std::vector<double> euler_step_response(double u, double w_per_frame, int frames) {
  double x = 0, v = 0;
  const int sub = 1000;
  const double h = 1.0 / sub;
  std::vector<double> out;
  for (int f = 0; f < frames; ++f) {
    for (int s = 0; s < sub; ++s) {
      const double a = w_per_frame * w_per_frame * (u - x) - 2 * w_per_frame * v;
      x += h * v;
      v += h * a;
    }
    out.push_back(x);
  }
  return out;
}

TEST(RootController, DeltaFilterIsTheCriticallyDampedStepResponse) {
  const double fps = 20, sigma = 0.7, w = 1.31 / (sigma * fps);
  RootController c(options(fps, sigma));
  const auto reference = euler_step_response(0.065, w, 60);
  for (int f = 0; f < 60; ++f) {
    const auto out = c.step(RootController::Control{0.0, 0.065, 0.0});
    // Closed form from rest: u (1 - (1 + w t) e^{-w t}).
    const double t = f + 1, closed = 0.065 * (1 - (1 + w * t) * std::exp(-w * t));
    EXPECT_NEAR(out[1], closed, 1e-12) << f;
    EXPECT_NEAR(out[1], reference[f], 2e-5) << f;
    EXPECT_EQ(out[0], 0.0);
  }
}

TEST(RootController, RiseTimeMatchesTheTrainingGaussian) {
  // 10-90% of a step in 2.56 sigma (a Gaussian-smoothed step's rise), within a frame at 100 fps.
  const double fps = 100, sigma = 0.5;
  RootController c(options(fps, sigma));
  int t10 = -1, t90 = -1;
  for (int f = 1; f < 1000; ++f) {
    const double y = c.step(RootController::Control{0.0, 1.0, 0.0})[1];
    if (t10 < 0 && y >= 0.1) t10 = f;
    if (t90 < 0 && y >= 0.9) t90 = f;
  }
  EXPECT_NEAR((t90 - t10) / fps, 2.56 * sigma, 0.02 * 2.56 * sigma + 1.0 / fps);
}

TEST(RootController, PredictionEqualsSteppingWithTheInputHeld) {
  RootController c(options(30, 0.35));
  const RootController::Control inputs[] = {{0.01, 0.04, 0.02}, {0.0, 0.05, -0.01}, {-0.02, 0.0, 0.03}};
  for (const auto& in : inputs) {
    for (int k = 0; k < 7; ++k) c.step(in);
    std::vector<float> predicted(20 * 3);
    c.predict(20, predicted.data());
    RootController copy = c;
    for (int k = 0; k < 20; ++k) {
      const auto out = copy.step(in);
      for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(predicted[k * 3 + i], static_cast<float>(out[i]));
    }
  }
  // predict() leaves the controller as it was.
  RootController a(options(30, 0.35)), b(options(30, 0.35));
  a.step(inputs[0]);
  b.step(inputs[0]);
  std::vector<float> scratch(30);
  a.predict(10, scratch.data());
  EXPECT_EQ(a.step(inputs[1]), b.step(inputs[1]));
}

TEST(RootController, WithoutFilteringDeltasPassAndThePredictionHoldsThem) {
  RootController c(options(20, 0.0));
  const RootController::Control in{0.01, 0.06, 0.02};
  EXPECT_EQ(c.step(in), in);
  std::vector<float> predicted(5 * 3);
  c.predict(5, predicted.data());
  for (int k = 0; k < 5; ++k)
    for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(predicted[k * 3 + i], static_cast<float>(in[i]));
}

// The root path the controller's deltas trace (metres, heading 0 = +z), as Generator::root does.
GroundTrajectory integrate(const std::vector<RootController::Control>& deltas) {
  Skeleton sk;
  sk.joint_names = {"root"};
  sk.parents = {-1};
  sk.offsets = {Eigen::Vector3d::Zero()};
  std::vector<RootDelta> d(1);
  for (const auto& c : deltas) d.push_back(RootDelta{c[0], c[1], c[2]});
  return integrate_root_deltas(sk, d, Eigen::Vector3d::Zero(), 0.0);
}

TEST(RootController, StickReachesItsWorldVelocityAndFacing) {
  const double fps = 20;
  RootController c(options(fps, 0.35));
  // Walk along +x at 1.2 m/s facing +x (heading +pi/2).
  const StickInput stick{1.2, 0.0, M_PI / 2};
  std::vector<RootController::Control> deltas;
  for (int f = 0; f < 200; ++f) deltas.push_back(c.step(stick));
  EXPECT_NEAR(c.heading_rad(), M_PI / 2, 1e-6);
  const auto path = integrate(deltas);
  const auto& p = path.positions;
  const Eigen::Vector3d last_second = p.back() - p[p.size() - 1 - 20];
  EXPECT_NEAR(last_second.x(), 1.2, 1e-4);
  EXPECT_NEAR(last_second.z(), 0.0, 1e-4);
  // In the character's frame: all forward, no sideways, no turn.
  EXPECT_NEAR(deltas.back()[1], 1.2 / fps, 1e-6);
  EXPECT_NEAR(deltas.back()[0], 0.0, 1e-6);
  EXPECT_NEAR(deltas.back()[2], 0.0, 1e-8);
}

TEST(RootController, StickTakesTheShorterWayRound) {
  RootController c(options(20, 0.35));
  for (int f = 0; f < 100; ++f) c.step(StickInput{0, 0, 3.0});
  EXPECT_NEAR(c.heading_rad(), 3.0, 1e-6);
  // From 3.0 to -3.0 is 0.28 rad through pi, not 6 rad back through 0.
  for (int f = 0; f < 100; ++f) c.step(StickInput{0, 0, -3.0});
  EXPECT_NEAR(c.heading_rad(), 2 * M_PI - 3.0, 1e-6);
}

TEST(RootController, AStoppedStickStandsStillAndSwitchingModesIsSmooth) {
  RootController c(options(20, 0.35));
  for (int f = 0; f < 60; ++f) c.step(RootController::Control{0.0, 0.06, 0.01});
  const auto before = c.step(RootController::Control{0.0, 0.06, 0.01});
  // The stick takes over at the filtered delta's velocity: the first stick step barely changes it.
  const double heading = c.heading_rad();
  const StickInput same{0.06 * 20 * std::sin(heading), 0.06 * 20 * std::cos(heading), heading + 0.2};
  const auto after = c.step(same);
  EXPECT_NEAR(after[1], before[1], 2e-3);
  for (int f = 0; f < 400; ++f) c.step(StickInput{0, 0, c.heading_rad()});
  const auto still = c.step(StickInput{0, 0, c.heading_rad()});
  for (double v : still) EXPECT_NEAR(v, 0.0, 1e-6);
}

}  // namespace
}  // namespace mosyn::data
