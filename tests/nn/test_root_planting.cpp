// Root planting as runs apply it (nn/root_planting.h): the config section, offline sampling and
// the real-time Generator on the shipped hvrnn model, whose root motion is its own.
#include "nn/root_planting.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/kinematics.h"
#include "data/representation.h"
#include "nn/generator.h"
#include "nn/run.h"
#include "nn/sampling.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

const std::string kModel = std::string(MOSYN_SOURCE_DIR) + "/models/hvrnn-bandai";

// Fraction of frames in which a toe within 1 cm of its lowest height slides faster than 10 cm/s
// (../shared/checks/natural_motion.py's skating measure, on the clip's toes).
double skating(const LoadedRun& run, const SampledMotion& m) {
  const Clip clip = decode_motion(run, m);
  const WorldPoses w = forward_kinematics(clip.skeleton, clip.motion);
  const double mpu = clip.skeleton.meters_per_unit, fps = clip.motion.fps;
  const int up = clip.skeleton.up_axis;
  std::vector<int> toes;
  for (const auto& leg : foot_points(clip.skeleton))
    if (leg.size() > 1) toes.push_back(leg[1]);
  std::vector<double> floor(toes.size(), 1e9);
  for (int t = 0; t < w.num_frames; ++t)
    for (size_t k = 0; k < toes.size(); ++k) floor[k] = std::min(floor[k], w.position(t, toes[k])[up] * mpu);
  int sliding = 0;
  for (int t = 1; t < w.num_frames; ++t) {
    bool any = false;
    for (size_t k = 0; k < toes.size(); ++k) {
      Eigen::Vector3d v = w.position(t, toes[k]) - w.position(t - 1, toes[k]);
      const bool low = w.position(t - 1, toes[k])[up] * mpu - floor[k] < 0.01;
      v[up] = 0;
      any = any || (low && v.norm() * mpu * fps > 0.10);
    }
    sliding += any ? 1 : 0;
  }
  return static_cast<double>(sliding) / (w.num_frames - 1);
}

}  // namespace

TEST(RootPlantingConfig, ReadsTheSectionAndNamesTheFileOnErrors) {
  EXPECT_FALSE(root_planting_from_config(nlohmann::json::object(), "run/config.json").has_value());
  const auto defaults = root_planting_from_config({{"root_planting", nlohmann::json::object()}}, "run/config.json");
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->contact_height_m, RootPlantingOptions{}.contact_height_m);
  const auto set = root_planting_from_config({{"root_planting", {{"release_height_m", 0.08}}}}, "c.json");
  EXPECT_EQ(set->release_height_m, 0.08);
  for (const nlohmann::json& bad : {nlohmann::json{{"root_planting", true}},
                                    nlohmann::json{{"root_planting", {{"contact_height", 0.1}}}},
                                    nlohmann::json{{"root_planting", {{"release_height_m", 0.01}}}},
                                    nlohmann::json{{"root_planting", {{"floor_window_s", "2"}}}}}) {
    try {
      root_planting_from_config(bad, "run/config.json");
      ADD_FAILURE() << "accepted " << bad.dump();
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("run/config.json"), std::string::npos) << e.what();
    }
  }
}

// The shipped hvrnn plants its steps: the poses are the model's own, the toes slide in fewer
// frames than with the model's raw steps, and the Generator gives the frames sample_motions does.
TEST(RootPlantingShipped, PlantedStepsKeepThePosesAndStopTheSlide) {
  if (!std::filesystem::exists(kModel + "/checkpoint.pt")) GTEST_SKIP() << "no shipped model";
  LoadedRun run = load_run(kModel, LoadOptions{"checkpoint.pt", "cpu", 1});
  ASSERT_TRUE(run.root_planting.has_value()) << "models/hvrnn-bandai/config.json plants its root";
  LoadOptions unplanted{"checkpoint.pt", "cpu", 1};
  unplanted.raw_root = true;
  EXPECT_FALSE(load_run(kModel, unplanted).root_planting.has_value());
  const int frames = 150, n = 2;
  SampleExtras extras;
  extras.content = 0;  // walk
  extras.style = 0;
  const std::vector<float> control(static_cast<size_t>(frames) * 3, 0.0f);
  const auto planted = sample_motions(run, control, n, 5, 1.0, extras);
  extras.raw_root = true;
  const auto raw = sample_motions(run, control, n, 5, 1.0, extras);
  double planted_skating = 0, raw_skating = 0;
  for (int i = 0; i < n; ++i) {
    EXPECT_EQ(planted[i].pose, raw[i].pose);
    EXPECT_NE(planted[i].control, raw[i].control);
    planted_skating += skating(run, planted[i]) / n;
    raw_skating += skating(run, raw[i]) / n;
  }
  EXPECT_LT(planted_skating, 0.5 * raw_skating) << planted_skating << " against " << raw_skating;

  GeneratorOptions o;
  o.batch = n;
  o.seed = 5;
  o.content = {0, 0};
  o.style = {0, 0};
  o.threads = 1;
  Generator gen(std::move(run), o);
  for (int t = 0; t < frames; ++t) {
    const std::vector<float> pose = gen.step({});
    for (int i = 0; i < n; ++i) {
      for (int k = 0; k < 3; ++k)
        ASSERT_NEAR(gen.last_control()[i * 3 + k], planted[i].control[t * 3 + k], 1e-5) << "frame " << t;
      ASSERT_NEAR(pose[i * gen.pose_dim()], planted[i].pose[t * gen.pose_dim()], 1e-4) << "frame " << t;
    }
  }
}
