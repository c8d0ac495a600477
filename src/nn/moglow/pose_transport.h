// The previous frame's joint positions carried into the current frame's root frame: what MoGlow's
// residual parameterisation (MoGlowOptions::residual) subtracts from each frame before the flow.
//
// Position features are joint positions relative to the root path at frame t, in its heading
// frame (data/representation.h); the control of frame t is the root's step from t-1 to t in the
// ground frame of t-1: sideways dx and forward dz (metres) and the turn dtheta (radians). A point
// fixed in the world at p in frame t-1 is, in frame t, (core/trajectory.h integrate_root_deltas)
//   q = p - (dx along the sideways axis, dz along the forward axis),
//   p'[side] = cos(dtheta) q[side] - sin(dtheta) q[fwd],  p'[fwd] = sin(dtheta) q[side] + cos(dtheta) q[fwd],
// and keeps its up coordinate. A planted foot is exactly there, so the residual x_t - p'_t is 0 for it
// (2 mm median on Bandai-Namco's held-out locomotion, against 7.7 cm for x_t - x_{t-1}).
#pragma once

#include <torch/types.h>

#include "nn/context.h"

namespace mosyn::nn {

class PoseTransport {
 public:
  PoseTransport() = default;
  // From a positions-form context (pose_dim = 3 J, control (dx, dz, dtheta)): the features'
  // statistics (all zero mean, unit std when the context has none, as in hand-built test contexts)
  // and the skeleton's up axis (Y when it has no joints). Throws mosyn::Error for other forms.
  explicit PoseTransport(const ModelContext& context);

  // prev [..., D] and control [..., C], standardised -> the transported previous pose [..., D],
  // standardised. Differentiable; any dtype and device (statistics are moved to them).
  torch::Tensor apply(const torch::Tensor& prev, const torch::Tensor& control) const;

 private:
  torch::Tensor pose_mean_, pose_std_, control_mean_, control_std_;  // [D], [D], [C], [C] float64, CPU
  int64_t side_axis_ = 0, forward_axis_ = 2;
};

}  // namespace mosyn::nn
