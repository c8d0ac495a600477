#include "nn/foot_contact.h"

#include "core/error.h"
#include "core/foot_lock.h"
#include "nn/kinematics.h"

namespace mosyn::nn {

PlantedHeelTerm::PlantedHeelTerm(const ModelContext& context, const std::string& family) : fps_(context.fps) {
  const Skeleton& skeleton = context.skeleton;
  const std::string who = family + ": a heel term (foot_contact_weight, heel_speed_weight) needs ";
  if (context.pose_form != data::PoseForm::kPositions || skeleton.num_joints() * 3 != context.pose_dim)
    throw Error(who + "the positions form with the dataset's skeleton (a model built by mosyn train or load_run)");
  const auto& st = context.stats;
  if (static_cast<int>(st.pose_std.size()) != context.pose_dim ||
      static_cast<int>(st.control_std.size()) != context.control_dim)
    throw Error(who + "the dataset statistics (a model built by mosyn train or load_run)");
  for (const LegChain& leg : find_legs(skeleton)) heels_.push_back(leg.ankle);
  if (heels_.size() != 2)
    throw Error(who + "exactly two legs (ankles named Foot or Ankle); the skeleton has " + std::to_string(heels_.size()));
  pose_mean_ = torch::tensor(st.pose_mean);
  pose_std_ = torch::tensor(st.pose_std);
  control_mean_ = torch::tensor(st.control_mean);
  control_std_ = torch::tensor(st.control_std);
}

std::pair<torch::Tensor, torch::Tensor> PlantedHeelTerm::heel_speeds_mps(const torch::Tensor& made,
                                                                         const torch::Tensor& real,
                                                                         const torch::Tensor& control) const {
  if (heels_.empty()) throw Error("PlantedHeelTerm: not built from a model context");
  const auto opts = made.options();
  const auto pm = pose_mean_.to(opts), ps = pose_std_.to(opts);
  const auto ctrl = control.to(opts) * control_std_.to(opts) + control_mean_.to(opts);
  return {joint_ground_speed_mps(made * ps + pm, ctrl, heels_, fps_),
          joint_ground_speed_mps(real.to(opts) * ps + pm, ctrl, heels_, fps_)};
}

torch::Tensor PlantedHeelTerm::mean_planted_speed(const torch::Tensor& made, const torch::Tensor& real,
                                                  const torch::Tensor& control, const torch::Tensor& valid) const {
  const auto [made_mps, real_mps] = heel_speeds_mps(made, real, control);  // [B, T-1, 2]
  auto planted = (real_mps < kPlantedMps).to(made_mps.dtype());
  if (valid.defined()) planted = planted * valid.to(made.options()).unsqueeze(-1);
  return (made_mps * planted).sum() / planted.sum().clamp_min(1.0);
}

torch::Tensor PlantedHeelTerm::mean_lingering_speed(const torch::Tensor& made, const torch::Tensor& real,
                                                    const torch::Tensor& control, const torch::Tensor& valid) const {
  const auto [made_mps, real_mps] = heel_speeds_mps(made, real, control);  // [B, T-1, 2]
  auto lifted = (real_mps >= kPlantedMps).to(made_mps.dtype());
  if (valid.defined()) lifted = lifted * valid.to(made.options()).unsqueeze(-1);
  return (torch::relu(kPlantedMps - made_mps) * lifted).sum() / lifted.sum().clamp_min(1.0);
}

torch::Tensor PlantedHeelTerm::mean_speed_error(const torch::Tensor& made, const torch::Tensor& real,
                                                const torch::Tensor& control, const torch::Tensor& valid) const {
  const auto [made_mps, real_mps] = heel_speeds_mps(made, real, control);  // [B, T-1, 2]
  auto counted = torch::ones_like(made_mps);
  if (valid.defined()) counted = counted * valid.to(made.options()).unsqueeze(-1);
  return ((made_mps - real_mps).abs() * counted).sum() / counted.sum().clamp_min(1.0);
}

}  // namespace mosyn::nn
