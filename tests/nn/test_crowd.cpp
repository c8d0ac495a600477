// The crowd runtime on the shipped MoGlow: a character's motion depends only on its own seed,
// labels and controls, never on its batch mates or its slot (up to float rounding: BLAS kernels
// round a row differently in matrices of other heights); characters are added and removed per
// slot and replay bit for bit; the engine-facing joint transforms are unit quaternions that rebuild the
// character's raw pose.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/kinematics.h"
#include "data/representation.h"
#include "nn/generator.h"
#include "nn/model.h"
#include "nn/run.h"

using namespace mosyn;

namespace {

const std::string kModel = MOSYN_SOURCE_DIR "/models/moglow-locomotion";

// The shipped model, loaded once for the suite.
const nn::LoadedRun& shipped() {
  static const nn::LoadedRun run = nn::load_run(kModel, {"checkpoint.pt", "cpu", 1});
  return run;
}

// Control of character "id" at frame f: forward at its own speed, turning its own way.
std::vector<float> control_of(int id, int f, double fps) {
  const double speed = 0.6 + 0.15 * (id % 7), turn = 0.3 * std::sin(0.05 * f + id);
  return {0.0f, static_cast<float>(speed / fps), static_cast<float>(turn / fps)};
}

nn::GeneratorOptions options_of(int batch, int threads) {
  nn::GeneratorOptions o;
  o.batch = batch;
  o.threads = threads;
  o.warmup_frames = 5;
  return o;
}

// Frames [T][D] of one character (seed, style, id) alone in a batch of one.
std::vector<std::vector<float>> alone(std::uint64_t seed, int style, int id, int frames, int threads) {
  auto o = options_of(1, threads);
  o.seed = seed;
  o.style = {style};
  nn::Generator g(shipped(), o);
  std::vector<std::vector<float>> out;
  for (int f = 0; f < frames; ++f) out.push_back(g.step(control_of(id, f, shipped().dataset.fps)));
  return out;
}

std::vector<float> row(const std::vector<float>& batch, int k, int d) {
  return std::vector<float>(batch.begin() + k * d, batch.begin() + (k + 1) * d);
}

// Largest absolute difference (metres: joint positions relative to the root).
double max_diff(const std::vector<float>& a, const std::vector<float>& b) {
  double m = a.size() == b.size() ? 0.0 : 1e9;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) m = std::max(m, static_cast<double>(std::fabs(a[i] - b[i])));
  return m;
}

// 0.05 mm: float rounding, far below any visible difference; another character differs by cm.
constexpr double kRounding = 5e-5;

}  // namespace

// A character added to slot 5 of a batch of 9 mid-stream, among batch mates with other seeds,
// styles and controls, generates what it generates alone, up to float rounding (1 and 2 threads).
TEST(Crowd, CharacterIndependentOfBatchMatesAndSlot) {
  for (int threads : {1, 2}) {
    const int frames = 12, b = 9, d = shipped().context.pose_dim, slot = 5, id = 3;
    const std::uint64_t seed = 1234;
    const auto reference = alone(seed, 2, id, frames, threads);
    auto o = options_of(b, threads);
    o.seed = 99;
    o.style = {0, 1, 2, 3, 4, 5, 6, 0, 1};
    nn::Generator g(shipped(), o);
    std::vector<float> control;
    const double fps = shipped().dataset.fps;
    auto controls = [&](int f) {
      control.clear();
      for (int k = 0; k < b; ++k) {
        const auto c = control_of(k == slot ? id : 10 + k, f, fps);
        control.insert(control.end(), c.begin(), c.end());
      }
      return control;
    };
    for (int f = 0; f < 4; ++f) g.step(controls(100 + f));  // the others walk a while first
    nn::CharacterOptions character;
    character.seed = seed;
    character.style = 2;
    g.add(slot, character);
    for (int f = 0; f < frames; ++f) {
      const auto pose = g.step(controls(f));
      ASSERT_LT(max_diff(row(pose, slot, d), reference[f]), kRounding) << "threads " << threads << " frame " << f;
    }
  }
}

// Slot k of a batch started with seed s behaves as a character added alone with row_seed(s, k);
// different seeds give different motion.
TEST(Crowd, StartedBatchRowsUseRowSeeds) {
  const int b = 4, d = shipped().context.pose_dim, frames = 6;
  auto o = options_of(b, 1);
  o.seed = 7;
  o.style = {3};
  nn::Generator g(shipped(), o);
  std::vector<std::vector<float>> poses;
  for (int f = 0; f < frames; ++f) {
    std::vector<float> control;
    for (int k = 0; k < b; ++k) {
      const auto c = control_of(2, f, shipped().dataset.fps);
      control.insert(control.end(), c.begin(), c.end());
    }
    poses.push_back(g.step(control));
  }
  for (int k : {0, 3}) {
    const auto ref = alone(nn::row_seed(7, k), 3, 2, frames, 1);
    for (int f = 0; f < frames; ++f) ASSERT_LT(max_diff(row(poses[f], k, d), ref[f]), kRounding) << "row " << k << " frame " << f;
  }
  EXPECT_GT(max_diff(row(poses[frames - 1], 0, d), row(poses[frames - 1], 1, d)), 1e-3);  // same controls, other seeds
}

// Removing a character freezes its slot (zeros out, root still) without touching the others;
// adding it again with the same seed replays its motion bit for bit.
TEST(Crowd, RemoveAndExactReplay) {
  const int b = 3, d = shipped().context.pose_dim, frames = 8;
  const double fps = shipped().dataset.fps;
  auto o = options_of(b, 1);
  o.seed = 5;
  nn::Generator g(shipped(), o);
  auto step_all = [&](int f) {
    std::vector<float> control;
    for (int k = 0; k < b; ++k) {
      const auto c = control_of(k, f, fps);
      control.insert(control.end(), c.begin(), c.end());
    }
    return g.step(control);
  };
  nn::CharacterOptions c;
  c.seed = 77;
  c.content = 0;
  g.add(1, c);
  std::vector<std::vector<float>> first;
  for (int f = 0; f < frames; ++f) first.push_back(row(step_all(f), 1, d));
  g.remove(1);
  EXPECT_FALSE(g.active(1));
  const auto root_before = g.root(1).position;
  const auto frozen = step_all(0);
  EXPECT_EQ(row(frozen, 1, d), std::vector<float>(d, 0.0f));
  EXPECT_EQ(g.root(1).position, root_before);
  g.add(1, c);
  EXPECT_TRUE(g.active(1));
  EXPECT_EQ(g.root(1).position, Eigen::Vector3d::Zero());
  for (int f = 0; f < frames; ++f) ASSERT_EQ(row(step_all(f), 1, d), first[f]) << "frame " << f;
  EXPECT_THROW(g.add(3, c), Error);
  EXPECT_THROW(g.remove(-1), Error);
}

// Joint transforms: J unit quaternions and the root joint's translation, at the character's root;
// through forward kinematics they give the joints where decoding its raw pose at its root puts them.
TEST(Crowd, JointTransformsRebuildThePose) {
  auto o = options_of(2, 1);
  o.seed = 3;
  nn::Generator g(shipped(), o);
  const auto& info = shipped().dataset;
  const int j = info.skeleton.num_joints();
  EXPECT_EQ(g.joint_transforms(0).rotations_wxyz.size(), static_cast<size_t>(4 * j));  // rest pose first
  std::vector<float> pose;
  for (int f = 0; f < 10; ++f) {
    std::vector<float> control;
    for (int k = 0; k < 2; ++k) {
      const auto c = control_of(k, f, info.fps);
      control.insert(control.end(), c.begin(), c.end());
    }
    pose = g.step(control);
  }
  for (int k = 0; k < 2; ++k) {
    const auto t = g.joint_transforms(k);
    ASSERT_EQ(t.rotations_wxyz.size(), static_cast<size_t>(4 * j));
    Motion m = Motion::rest(info.skeleton, 1, info.fps);
    for (int q = 0; q < j; ++q) {
      const float* r = &t.rotations_wxyz[4 * q];
      EXPECT_NEAR(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3], 1.0, 1e-5);
      m.rotation(0, q) = Eigen::Quaterniond(r[0], r[1], r[2], r[3]);
    }
    m.translation(0, 0) = t.root_translation;
    const std::vector<float> still(3, 0.0f);
    const Motion expected = data::decode(info.skeleton, info.layout, pose.data() + k * shipped().context.pose_dim,
                                         still.data(), 1, info.fps, g.root(k).position, g.root(k).heading_rad);
    const auto got = forward_kinematics(info.skeleton, m), want = forward_kinematics(info.skeleton, expected);
    ASSERT_EQ(got.positions.size(), want.positions.size());
    for (size_t i = 0; i < got.positions.size(); ++i)  // float quaternions: skeleton units of ~100 per metre
      EXPECT_LT((got.positions[i] - want.positions[i]).norm(), 1e-3) << "joint " << i;
  }
}
