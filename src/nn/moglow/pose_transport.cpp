#include "nn/moglow/pose_transport.h"

#include <string>

#include "core/error.h"

namespace mosyn::nn {

namespace {

// stats [n] as a float64 tensor, or `fill` repeated n times when the context has none.
torch::Tensor stat(const std::vector<float>& values, int64_t n, double fill, const char* what) {
  if (values.empty()) return torch::full({n}, fill, torch::kFloat64);
  if (static_cast<int64_t>(values.size()) != n)
    throw Error(std::string("moglow residual: the context's ") + what + " has " + std::to_string(values.size()) +
                " entries, expected " + std::to_string(n));
  return torch::tensor(std::vector<double>(values.begin(), values.end()), torch::kFloat64);
}

}  // namespace

PoseTransport::PoseTransport(const ModelContext& context) {
  if (context.pose_form != data::PoseForm::kPositions || context.pose_dim % 3 != 0 || context.control_dim != 3)
    throw Error("moglow: residual needs joint-position features (pose form positions, D = 3 J) and the root "
                "control (dx, dz, dtheta); this data has pose form " +
                std::string(data::to_string(context.pose_form)) + ", D = " + std::to_string(context.pose_dim) +
                ", C = " + std::to_string(context.control_dim) +
                " (prepare the data with `mosyn data prepare ... --form positions`)");
  pose_mean_ = stat(context.stats.pose_mean, context.pose_dim, 0.0, "pose mean");
  pose_std_ = stat(context.stats.pose_std, context.pose_dim, 1.0, "pose std");
  control_mean_ = stat(context.stats.control_mean, 3, 0.0, "control mean");
  control_std_ = stat(context.stats.control_std, 3, 1.0, "control std");
  // As core/trajectory.cpp: forward = (up + 1) mod 3, sideways = (up + 2) mod 3 (Y up: Z, X).
  const int up = context.skeleton.up_axis;
  if (up < 0 || up > 2) throw Error("moglow residual: skeleton up_axis must be 0, 1 or 2");
  forward_axis_ = (up + 1) % 3;
  side_axis_ = (up + 2) % 3;
}

torch::Tensor PoseTransport::apply(const torch::Tensor& prev, const torch::Tensor& control) const {
  if (!pose_mean_.defined()) throw Error("moglow residual: transport used without a context");
  const auto o = prev.options();
  auto p = prev * pose_std_.to(o) + pose_mean_.to(o);
  auto joints = p.reshape({-1, p.size(-1) / 3, 3});  // [N, J, 3] metres
  auto c = (control * control_std_.to(o) + control_mean_.to(o)).reshape({-1, 1, 3});
  auto dx = c.select(2, 0), dz = c.select(2, 1), turn = c.select(2, 2);  // [N, 1]
  auto side = joints.select(2, side_axis_) - dx, fwd = joints.select(2, forward_axis_) - dz;
  auto cos = torch::cos(turn), sin = torch::sin(turn);
  std::vector<torch::Tensor> axes(3);
  axes[side_axis_] = cos * side - sin * fwd;
  axes[forward_axis_] = sin * side + cos * fwd;
  const int64_t up = 3 - side_axis_ - forward_axis_;
  axes[up] = joints.select(2, up);
  auto moved = torch::stack(axes, 2).reshape(prev.sizes());
  return (moved - pose_mean_.to(o)) / pose_std_.to(o);
}

}  // namespace mosyn::nn
