#include "nn/foot_contact.h"

#include "core/error.h"
#include "core/foot_lock.h"
#include "nn/kinematics.h"

namespace mosyn::nn {

PlantedHeelTerm::PlantedHeelTerm(const ModelContext& context, const std::string& family) : fps_(context.fps) {
  const Skeleton& skeleton = context.skeleton;
  if (context.pose_form != data::PoseForm::kPositions || skeleton.num_joints() * 3 != context.pose_dim)
    throw Error(family + ": foot_contact_weight needs the positions form with the dataset's skeleton (a model built "
                "by mosyn train or load_run)");
  const auto& st = context.stats;
  if (static_cast<int>(st.pose_std.size()) != context.pose_dim ||
      static_cast<int>(st.control_std.size()) != context.control_dim)
    throw Error(family + ": foot_contact_weight needs the dataset statistics (a model built by mosyn train or load_run)");
  for (const LegChain& leg : find_legs(skeleton)) heels_.push_back(leg.ankle);
  if (heels_.size() != 2)
    throw Error(family + ": foot_contact_weight needs exactly two legs (ankles named Foot or Ankle); the skeleton has " +
                std::to_string(heels_.size()));
  pose_mean_ = torch::tensor(st.pose_mean);
  pose_std_ = torch::tensor(st.pose_std);
  control_mean_ = torch::tensor(st.control_mean);
  control_std_ = torch::tensor(st.control_std);
}

torch::Tensor PlantedHeelTerm::mean_planted_speed(const torch::Tensor& made, const torch::Tensor& real,
                                                  const torch::Tensor& control, const torch::Tensor& valid) const {
  if (heels_.empty()) throw Error("PlantedHeelTerm: not built from a model context");
  const auto opts = made.options();
  const auto pm = pose_mean_.to(opts), ps = pose_std_.to(opts);
  const auto ctrl = control.to(opts) * control_std_.to(opts) + control_mean_.to(opts);
  const auto real_mps = joint_ground_speed_mps(real.to(opts) * ps + pm, ctrl, heels_, fps_);
  const auto made_mps = joint_ground_speed_mps(made * ps + pm, ctrl, heels_, fps_);  // [B, T-1, 2]
  auto planted = (real_mps < kPlantedMps).to(made_mps.dtype());
  if (valid.defined()) planted = planted * valid.to(opts).unsqueeze(-1);
  return (made_mps * planted).sum() / planted.sum().clamp_min(1.0);
}

}  // namespace mosyn::nn
