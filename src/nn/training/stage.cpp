#include "nn/training/stage.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "core/error.h"

namespace mosyn::nn {

double noam_lr(double peak_lr, int warmup, int step) {
  if (warmup <= 0) return peak_lr;
  const double s = std::max(step, 1);
  return peak_lr * std::min(s / warmup, std::sqrt(static_cast<double>(warmup) / s));
}

double scheduled_lr(const ScheduleSpec& schedule, double peak_lr, int step, int total_steps) {
  switch (schedule.kind) {
    case ScheduleSpec::Kind::kNoam:
      return noam_lr(peak_lr, schedule.warmup, step);
    case ScheduleSpec::Kind::kConstant:
      return peak_lr;
    case ScheduleSpec::Kind::kCosine: {
      const int s = std::max(step, 1);
      if (schedule.warmup > 0 && s <= schedule.warmup) return peak_lr * s / schedule.warmup;
      const int span = total_steps - schedule.warmup;
      if (span <= 0) return peak_lr;
      const double t = std::min(1.0, static_cast<double>(s - schedule.warmup) / span);
      return schedule.min_lr + 0.5 * (peak_lr - schedule.min_lr) * (1.0 + std::cos(M_PI * t));
    }
    case ScheduleSpec::Kind::kStep:
      return peak_lr * std::pow(schedule.gamma, (std::max(step, 1) - 1) / std::max(schedule.every, 1));
  }
  return peak_lr;
}

namespace {

// "" when the optimiser values are in range, else what is wrong.
std::string optimizer_problem(const OptimizerSpec& o) {
  if (!(o.lr > 0) || !std::isfinite(o.lr)) return "optimiser lr must be positive";
  if (!(o.weight_decay >= 0)) return "optimiser weight_decay must be >= 0";
  if (o.kind == OptimizerSpec::Kind::kSgd) {
    if (!(o.momentum >= 0 && o.momentum < 1)) return "SGD momentum must be in [0, 1)";
    return "";
  }
  if (!(o.beta1 >= 0 && o.beta1 < 1) || !(o.beta2 >= 0 && o.beta2 < 1)) return "Adam betas must be in [0, 1)";
  if (!(o.eps > 0)) return "Adam eps must be positive";
  return "";
}

// "" when the schedule values are in range, else what is wrong.
std::string schedule_problem(const ScheduleSpec& s) {
  if (s.warmup < 0) return "schedule warmup must be >= 0";
  if (s.kind == ScheduleSpec::Kind::kCosine && !(s.min_lr >= 0)) return "cosine schedule min_lr must be >= 0";
  if (s.kind == ScheduleSpec::Kind::kStep) {
    if (s.every < 1) return "step schedule 'every' must be >= 1";
    if (!(s.gamma > 0 && s.gamma <= 1)) return "step schedule gamma must be in (0, 1]";
  }
  return "";
}

}  // namespace

void check_stages(const std::vector<TrainingStage>& stages, const std::string& family) {
  if (stages.empty()) throw Error(family + ": the family declares no training stage");
  std::set<std::string> names;
  for (const auto& s : stages) {
    const std::string where = family + ": stage '" + s.name + "': ";
    if (s.name.empty()) throw Error(family + ": a training stage has no name");
    if (!names.insert(s.name).second) throw Error(where + "two stages have this name");
    if (s.steps < 1) throw Error(where + "steps must be >= 1");
    std::string problem = optimizer_problem(s.optimizer);
    if (problem.empty()) problem = schedule_problem(s.schedule);
    if (!problem.empty()) throw Error(where + problem);
    for (const auto& p : s.trained)
      if (p.empty()) throw Error(where + "an empty 'trained' prefix (leave the list empty to train everything)");
    for (const auto& p : s.frozen)
      if (p.empty()) throw Error(where + "an empty 'frozen' prefix");
  }
}

}  // namespace mosyn::nn
