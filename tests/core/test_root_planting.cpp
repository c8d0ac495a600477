#include "core/root_planting.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "core/kinematics.h"
#include "core/synthetic.h"
#include "core/trajectory.h"

namespace mosyn {
namespace {

// The biped's rest pose on the floor origin (ground frame, skeleton units).
std::vector<Eigen::Vector3d> rest_frame(const Skeleton& s) {
  return forward_kinematics(s, Motion::rest(s, 1, 30.0)).positions;
}

// Sets every foot point of the frame to `point_of(leg, k)`, other joints as they are.
template <class F>
void place_feet(const Skeleton& s, std::vector<Eigen::Vector3d>* frame, F point_of) {
  const auto legs = foot_points(s);
  for (size_t leg = 0; leg < legs.size(); ++leg)
    for (size_t k = 0; k < legs[leg].size(); ++k) (*frame)[legs[leg][k]] = point_of(leg, k);
}

TEST(RootPlanting, FootPointsAreEachAnkleAndItsToes) {
  const Skeleton s = make_synthetic_biped();
  const auto legs = foot_points(s);
  ASSERT_EQ(legs.size(), 2u);
  EXPECT_EQ(s.joint_names[legs[0][0]], "Foot_L");
  ASSERT_EQ(legs[0].size(), 2u);
  EXPECT_EQ(s.parents[legs[0][1]], legs[0][0]);
}

// Both feet stay at fixed floor points of the world while the root walks and turns; the model's
// steps are noise. The planted steps, integrated as the decoder does (integrate_root_deltas),
// give back the root path under the feet exactly: the feet do not move in the world.
TEST(RootPlanting, PlantedStepsKeepPlantedFeetStillInTheWorld) {
  const Skeleton s = make_synthetic_biped();  // centimetres, Y up
  RootPlanter planter(s, 30.0);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.02);
  const int frames = 40;
  std::vector<Eigen::Vector3d> root(frames);
  std::vector<double> heading(frames);
  std::vector<RootDelta> steps(frames);
  for (int t = 0; t < frames; ++t) {
    root[t] = Eigen::Vector3d(3.0 * std::sin(0.1 * t), 0, 2.0 * t);
    heading[t] = 0.4 + 0.03 * t;
  }
  auto world_foot = [](size_t leg, size_t k) { return Eigen::Vector3d(leg ? -9.0 : 9.0, 0.0, 30.0 + 12.0 * k); };
  for (int t = 0; t < frames; ++t) {
    std::vector<Eigen::Vector3d> frame = rest_frame(s);
    const Eigen::Quaterniond undo = heading_rotation(s, heading[t]).conjugate();
    place_feet(s, &frame, [&](size_t leg, size_t k) { return Eigen::Vector3d(undo * (world_foot(leg, k) - root[t])); });
    const double turn = t > 0 ? heading[t] - heading[t - 1] : 0.0;
    const Eigen::Vector2d planted = planter.step(frame, Eigen::Vector2d(noise(rng), 0.013 + noise(rng)), turn);
    steps[t] = RootDelta{planted[0] / s.meters_per_unit, planted[1] / s.meters_per_unit, turn};
  }
  const GroundTrajectory path = integrate_root_deltas(s, steps, root[0], heading[0]);
  for (int t = 1; t < frames; ++t) {
    EXPECT_NEAR((path.positions[t] - root[t]).norm(), 0.0, 1e-6) << "frame " << t;
    EXPECT_NEAR(path.headings_rad[t], heading[t], 1e-12);
  }
}

// A foot in the air (a run's flight) leaves the model's step; halfway between the contact and
// release heights the step moves halfway towards the planted one.
TEST(RootPlanting, WeightFollowsTheHeightAboveTheFloor) {
  const Skeleton s = make_synthetic_biped();
  RootPlantingOptions o;
  o.contact_height_m = 0.02;
  o.release_height_m = 0.06;
  RootPlanter planter(s, 30.0, o);
  const Eigen::Vector2d model(0.01, 0.04);
  auto frame_at = [&](double height_cm, double back_cm) {
    std::vector<Eigen::Vector3d> f = rest_frame(s);
    place_feet(s, &f, [&](size_t leg, size_t k) {
      return Eigen::Vector3d(leg ? -9.0 : 9.0, height_cm, 20.0 + 12.0 * k - back_cm);
    });
    return f;
  };
  // On the floor, the feet moving back 3 cm a frame: the planted step is 3 cm forward.
  EXPECT_EQ(planter.step(frame_at(0, 0), model, 0.0), model);  // the first frame only records
  Eigen::Vector2d out = planter.step(frame_at(0, 3), model, 0.0);
  EXPECT_NEAR(out[0], 0.0, 1e-12);
  EXPECT_NEAR(out[1], 0.03, 1e-12);
  out = planter.step(frame_at(4, 6), model, 0.0);  // 4 cm up: weight (6 - 4) / (6 - 2) = 0.5
  EXPECT_NEAR(out[0], 0.005, 1e-12);
  EXPECT_NEAR(out[1], 0.035, 1e-12);
  out = planter.step(frame_at(20, 9), model, 0.0);  // in the air
  EXPECT_EQ(out, model);
  planter.reset();  // a new motion: its first frame only records again
  EXPECT_EQ(planter.step(frame_at(0, 0), model, 0.0), model);
}

TEST(RootPlanting, ASkeletonWithoutLegsKeepsItsSteps) {
  Skeleton s;
  s.joint_names = {"Root", "Spine"};
  s.parents = {-1, 0};
  s.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 10, 0)};
  RootPlanter planter(s, 30.0);
  EXPECT_FALSE(planter.has_feet());
  const std::vector<Eigen::Vector3d> frame(2, Eigen::Vector3d::Zero());
  for (int t = 0; t < 3; ++t) EXPECT_EQ(planter.step(frame, Eigen::Vector2d(0.1, 0.2), 0.1), Eigen::Vector2d(0.1, 0.2));
}

TEST(RootPlanting, BadOptionsAndFramesAreErrors) {
  const Skeleton s = make_synthetic_biped();
  RootPlantingOptions o;
  o.release_height_m = o.contact_height_m;
  EXPECT_THROW(RootPlanter(s, 30.0, o), Error);
  o = {};
  o.floor_window_s = 0;
  EXPECT_THROW(RootPlanter(s, 30.0, o), Error);
  EXPECT_THROW(RootPlanter(s, 0.0), Error);
  RootPlanter planter(s, 30.0);
  EXPECT_THROW(planter.step(std::vector<Eigen::Vector3d>(3), Eigen::Vector2d::Zero(), 0.0), Error);
}

}  // namespace
}  // namespace mosyn
