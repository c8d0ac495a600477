// Small synthetic inputs shared by the nn tests: a six-dimensional sinusoid dataset and batches
// of noisy sinusoids, plus a minimal model context.
#pragma once

#include <torch/torch.h>

#include <cmath>
#include <random>

#include "core/synthetic.h"
#include "data/dataset.h"
#include "data/representation.h"
#include "nn/model.h"

namespace mosyn::nn::testing {

constexpr int kDim = 6;  // positions of a two-joint skeleton

inline float d_sign(int t) { return (t / 10) % 2 ? 1.0f : -1.0f; }

inline data::ClipRecord sine_clip(std::mt19937& rng, int frames) {
  std::uniform_real_distribution<float> u(0, 6.28f), f(0.2f, 0.5f);
  std::normal_distribution<float> noise(0, 0.05f);
  data::ClipRecord c;
  c.num_frames = frames;
  const float phase = u(rng), freq = f(rng);
  for (int t = 0; t < frames; ++t) {
    for (int d = 0; d < kDim; ++d) c.pose.push_back(std::sin(freq * t + phase + 0.7f * d) + noise(rng));
    c.control.insert(c.control.end(), {freq, 0.0f, 0.01f * d_sign(t)});
  }
  return c;
}

// 6 training and 2 validation clips of 40 frames of noisy sinusoids (a two-joint skeleton's
// positions), with fixed statistics.
inline data::Dataset synthetic_dataset() {
  std::mt19937 rng(7);
  data::Dataset ds;
  auto& info = ds.info_;
  info.fps = 20;
  info.skeleton.joint_names = {"Root", "Tip"};
  info.skeleton.parents = {-1, 0};
  info.skeleton.offsets = {Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0)};
  info.layout.form = data::PoseForm::kPositions;
  info.layout.pose_dim = kDim;
  info.layout.control_dim = 3;
  for (int d = 0; d < kDim; ++d) info.layout.pose_names.push_back("p" + std::to_string(d));
  info.layout.control_names = {"dx_m", "dz_m", "dtheta_rad"};
  info.window_frames = 16;
  info.window_hop = 8;
  info.content_labels = {"walk"};
  for (int i = 0; i < 6; ++i) ds.train_.push_back(sine_clip(rng, 40));
  for (int i = 0; i < 2; ++i) ds.val_.push_back(sine_clip(rng, 40));
  ds.stats_.pose_mean.assign(kDim, 0.0f);
  ds.stats_.pose_std.assign(kDim, 0.7f);
  ds.stats_.control_mean = {0.35f, 0.0f, 0.0f};
  ds.stats_.control_std = {0.1f, 1.0f, 0.01f};
  return ds;
}

// Pose features and controls of a batch of noisy sinusoids [b, t, d] whose frequency is the
// first control channel: a tiny model can learn it within a few hundred steps.
inline Batch noisy_sinusoid_batch(int64_t b, int64_t t, int64_t d) {
  auto phase = torch::rand({b, 1, 1}) * 6.283;
  auto freq = 0.3 + torch::rand({b, 1, 1}) * 0.2;
  auto tt = torch::arange(t).reshape({1, t, 1});
  auto offs = torch::arange(d).reshape({1, 1, d}) * 0.7;
  auto pose = torch::sin(freq * tt + phase + offs) + 0.05 * torch::randn({b, t, d});
  auto control = torch::cat({freq.expand({b, t, 1}), torch::zeros({b, t, 2})}, -1);
  return Batch{pose, control, {}, {}};
}

inline ModelContext small_context(int d = 6, int c = 3) {
  ModelContext ctx;
  ctx.pose_dim = d;
  ctx.control_dim = c;
  return ctx;
}

// A positions-form context (data/representation.h, 30 fps) of skeleton s with unit statistics
// (standardised features are metres), as mosyn train builds for losses that need the skeleton.
inline ModelContext positions_context(const Skeleton& s) {
  ModelContext ctx;
  ctx.pose_form = data::PoseForm::kPositions;
  ctx.skeleton = s;
  ctx.layout = data::make_layout(s, data::PoseForm::kPositions, 0, estimate_forward_in_root(s), 0.3);
  ctx.pose_dim = ctx.layout.pose_dim;
  ctx.control_dim = 3;
  ctx.fps = 30;
  ctx.stats.pose_mean.assign(ctx.pose_dim, 0.0f);
  ctx.stats.pose_std.assign(ctx.pose_dim, 1.0f);
  ctx.stats.control_mean.assign(3, 0.0f);
  ctx.stats.control_std.assign(3, 1.0f);
  return ctx;
}

// A synthetic biped standing still for `frames` frames (every heel planted) as a batch of one in
// the features of positions_context(s).
inline Batch standing_batch(const Skeleton& s, const ModelContext& ctx, int frames) {
  SyntheticWalkOptions standing;
  standing.speed_mps = 0.0;
  standing.leg_swing_rad = 0.0;
  standing.sway_rad = 0.0;
  standing.cycle_hz = 0.0;  // knees, arms and bob hold their phase-0 pose
  std::vector<float> pose, control;
  data::encode(s, make_synthetic_walk(s, frames, ctx.fps, standing), ctx.layout, &pose, &control);
  return Batch{torch::from_blob(pose.data(), {1, frames, ctx.pose_dim}, torch::kFloat).clone(),
               torch::from_blob(control.data(), {1, frames, 3}, torch::kFloat).clone(), {}, {}};
}

}  // namespace mosyn::nn::testing
