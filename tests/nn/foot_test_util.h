// Contexts and windows of the synthetic biped (core/synthetic.h) in any pose form, for the tests of
// the shared foot objectives (nn/objectives/) and of the families that use them.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/synthetic.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "nn/model.h"

namespace mosyn::nn::testing {

// A context of skeleton s in `form` at fps (unit statistics: standardised features are raw),
// with the root path smoothed over smoothing_s (0: the raw path).
inline ModelContext form_context(const Skeleton& s, data::PoseForm form, double smoothing_s = 0.3,
                                 double fps = 30.0) {
  ModelContext ctx;
  ctx.pose_form = form;
  ctx.skeleton = s;
  ctx.layout = data::make_layout(s, form, 0, estimate_forward_in_root(s), smoothing_s);
  ctx.pose_dim = ctx.layout.pose_dim;
  ctx.control_dim = 3;
  ctx.fps = fps;
  ctx.stats.pose_mean.assign(ctx.pose_dim, 0.0f);
  ctx.stats.pose_std.assign(ctx.pose_dim, 1.0f);
  ctx.stats.control_mean.assign(3, 0.0f);
  ctx.stats.control_std.assign(3, 1.0f);
  return ctx;
}

// The features [1, T, D] and control [1, T, 3] of a motion in a context's layout.
inline Batch encoded_batch(const Skeleton& s, const Motion& m, const ModelContext& ctx) {
  std::vector<float> pose, control;
  data::encode(s, m, ctx.layout, &pose, &control);
  return Batch{torch::from_blob(pose.data(), {1, m.num_frames, ctx.pose_dim}, torch::kFloat).clone(),
               torch::from_blob(control.data(), {1, m.num_frames, 3}, torch::kFloat).clone(), {}, {}};
}

// `rows` copies of a synthetic walk of `frames` frames in the context's features.
inline Batch walk_batch(const Skeleton& s, const ModelContext& ctx, int frames, int rows = 2) {
  const Batch one = encoded_batch(s, make_synthetic_walk(s, frames, ctx.fps, SyntheticWalkOptions{}), ctx);
  return Batch{one.pose.repeat({rows, 1, 1}), one.control.repeat({rows, 1, 1}), {}, {}};
}

}  // namespace mosyn::nn::testing
