// The real-time generator's options on the shipped MoGlow model: live-control shaping and the
// streaming foot lock (nn/generator.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/foot_lock.h"
#include "core/kinematics.h"
#include "nn/generator.h"
#include "nn/sampling.h"

using namespace mosyn;
using namespace mosyn::nn;

namespace {

const std::string kModel = std::string(MOSYN_SOURCE_DIR) + "/models/moglow-locomotion";

// Horizontal ankle speeds (m/s) of a walk generated frame by frame, every frame decoded at the
// character's root.
std::vector<double> ankle_speeds(bool lock) {
  GeneratorOptions o;
  o.threads = 1;
  o.seed = 11;
  o.warmup_frames = 10;
  o.foot_lock = lock;
  Generator gen(kModel, o);
  const auto& info = gen.run().dataset;
  const auto legs = find_legs(info.skeleton);
  std::vector<Eigen::Vector3d> previous;
  std::vector<double> speeds;
  const float forward = static_cast<float>(1.2 / info.fps);
  for (int f = 0; f < 80; ++f) {
    const std::vector<float> pose = gen.step({0.0f, forward, 0.0f});
    const std::vector<float> still(3, 0.0f);
    const auto& root = gen.root(0);
    const Motion m = data::decode(info.skeleton, info.layout, pose.data(), still.data(), 1, info.fps, root.position,
                                  root.heading_rad);
    const WorldPoses w = forward_kinematics(info.skeleton, m);
    for (size_t k = 0; k < legs.size(); ++k) {
      Eigen::Vector3d a = w.position(0, legs[k].ankle);
      a[info.skeleton.up_axis] = 0;
      if (previous.size() == legs.size() && f > 10)
        speeds.push_back((a - previous[k]).norm() * info.skeleton.meters_per_unit * info.fps);
      if (previous.size() < legs.size()) previous.push_back(a);
      else previous[k] = a;
    }
  }
  return speeds;
}

double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(q * (v.size() - 1))];
}

}  // namespace

// With the lock, a fifth of the ankle frames stand still (planted); the raw model's feet slide.
TEST(GeneratorFootLock, PinsPlantedFeetOfTheShippedModel) {
  if (!std::filesystem::exists(kModel + "/checkpoint.pt")) GTEST_SKIP() << "no shipped model";
  const auto raw = ankle_speeds(false), locked = ankle_speeds(true);
  ASSERT_EQ(raw.size(), locked.size());
  EXPECT_LT(quantile(locked, 0.2), 0.5 * quantile(raw, 0.2));
  EXPECT_LT(quantile(locked, 0.2), 0.05);
}
