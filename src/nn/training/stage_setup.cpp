#include "nn/training/stage_setup.h"

#include <torch/optim/adam.h>
#include <torch/optim/adamw.h>
#include <torch/optim/sgd.h>

#include "core/error.h"

namespace mosyn::nn::training {

namespace {

// "encoder" matches "encoder" and "encoder.x", not "encoder2".
bool matches(const std::string& name, const std::string& prefix) {
  return name.compare(0, prefix.size(), prefix) == 0 && (name.size() == prefix.size() || name[prefix.size()] == '.');
}

bool matches_any(const std::string& name, const std::vector<std::string>& prefixes) {
  for (const auto& p : prefixes)
    if (matches(name, p)) return true;
  return false;
}

}  // namespace

StageParams resolve_stage(TrainableModel& model, const TrainingStage& stage) {
  const std::string where = model.family() + ": stage '" + stage.name + "': ";
  const auto named = model.named_parameters(/*recurse=*/true);
  const auto modules = model.named_modules("", /*include_self=*/false);
  for (const auto& prefix : stage.trained) {
    bool found = false;
    for (const auto& kv : named) found = found || matches(kv.key(), prefix);
    if (!found) throw Error(where + "no parameter matches the trained prefix '" + prefix + "'");
  }
  StageParams out;
  for (const auto& prefix : stage.frozen) {
    bool found = false;
    for (const auto& kv : modules)
      if (matches(kv.key(), prefix)) {
        found = true;
        out.frozen.push_back(kv.value());
      }
    for (const auto& kv : named) found = found || matches(kv.key(), prefix);
    if (!found) throw Error(where + "no module or parameter matches the frozen prefix '" + prefix + "'");
  }
  for (const auto& kv : named) {
    if (matches_any(kv.key(), stage.frozen)) continue;
    if (stage.trained.empty() || matches_any(kv.key(), stage.trained)) out.trained.push_back(kv.value());
  }
  if (out.trained.empty()) throw Error(where + "leaves no parameter to train");
  return out;
}

void restore_training_mode(TrainableModel& model, const StageParams& params) {
  model.train();
  for (const auto& m : params.frozen) m->eval();
}

void apply_training_mode(TrainableModel& model, const StageParams& params) {
  restore_training_mode(model, params);
  for (auto& p : model.parameters()) p.set_requires_grad(false);
  for (auto& p : params.trained) p.set_requires_grad(true);
}

std::unique_ptr<torch::optim::Optimizer> make_optimizer(const OptimizerSpec& spec, const StageParams& params) {
  switch (spec.kind) {
    case OptimizerSpec::Kind::kAdam:
      return std::make_unique<torch::optim::Adam>(params.trained, torch::optim::AdamOptions(spec.lr)
                                                                      .betas({spec.beta1, spec.beta2})
                                                                      .eps(spec.eps)
                                                                      .weight_decay(spec.weight_decay));
    case OptimizerSpec::Kind::kAdamW:
      return std::make_unique<torch::optim::AdamW>(params.trained, torch::optim::AdamWOptions(spec.lr)
                                                                       .betas({spec.beta1, spec.beta2})
                                                                       .eps(spec.eps)
                                                                       .weight_decay(spec.weight_decay));
    case OptimizerSpec::Kind::kSgd:
      return std::make_unique<torch::optim::SGD>(
          params.trained, torch::optim::SGDOptions(spec.lr).momentum(spec.momentum).weight_decay(spec.weight_decay));
  }
  throw Error("unknown optimiser kind");
}

void set_learning_rate(torch::optim::Optimizer& optimizer, double lr) {
  for (auto& group : optimizer.param_groups()) group.options().set_lr(lr);
}

std::string describe_stage(const TrainingStage& stage, int index, int count, const StageParams& params) {
  std::string text = "stage " + std::to_string(index + 1) + "/" + std::to_string(count) + " '" + stage.name +
                     "': " + std::to_string(stage.steps) + " steps, training " +
                     std::to_string(params.trained.size()) + " tensors";
  if (!stage.frozen.empty()) {
    text += ", frozen:";
    for (size_t i = 0; i < stage.frozen.size(); ++i) text += (i ? ", " : " ") + stage.frozen[i];
  }
  return text;
}

}  // namespace mosyn::nn::training
