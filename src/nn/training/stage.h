// Training stages: what the trainer (nn/training/train.h) runs, one after another. A stage says
// how many steps it takes, which parameters it trains, which modules it freezes, and its
// optimiser and learning-rate schedule. Families declare their stages through
// TrainableModel::training_stages (nn/trainable.h); most families have one stage built from the
// run's TrainOptions (default_training_stage), which trains every parameter with Adam and the Noam
// schedule. Header-only data plus a few pure functions; no LibTorch.
#pragma once

#include <string>
#include <vector>

namespace mosyn::nn {

// The optimiser of a stage. Every stage starts with a fresh optimiser (no moment estimates carried
// over from the previous stage); a checkpoint holds the state of the current stage's optimiser.
struct OptimizerSpec {
  enum class Kind {
    kAdam,   // torch::optim::Adam (L2 weight decay added to the gradient)
    kAdamW,  // torch::optim::AdamW (decoupled weight decay)
    kSgd,    // torch::optim::SGD with momentum
  };
  Kind kind = Kind::kAdam;
  double lr = 1e-3;            // peak learning rate; the schedule scales it step by step
  double beta1 = 0.9;          // Adam/AdamW: first-moment decay, in [0, 1)
  double beta2 = 0.999;        // Adam/AdamW: second-moment decay, in [0, 1)
  double eps = 1e-8;           // Adam/AdamW: denominator floor, > 0
  double weight_decay = 0.0;   // >= 0 (AdamW: decoupled; Adam, SGD: L2 on the gradient)
  double momentum = 0.0;       // SGD only, in [0, 1)
};

// The learning rate of a stage at its 1-based step s of N (scheduled_lr).
struct ScheduleSpec {
  enum class Kind {
    kNoam,      // lr * min(s / w, sqrt(w / s)); w = warmup (0 = constant lr). As the MoGlow paper.
    kConstant,  // lr at every step
    kCosine,    // linear warm-up over `warmup` steps, then lr -> min_lr along half a cosine at step N
    kStep,      // lr * gamma ^ floor((s - 1) / every): steps 1..every at lr, then lr * gamma, ...
  };
  Kind kind = Kind::kNoam;
  int warmup = 0;       // kNoam, kCosine: warm-up steps, >= 0
  double min_lr = 0.0;  // kCosine: the rate at the last step, >= 0
  int every = 1000;     // kStep: steps between decays, >= 1
  double gamma = 0.1;   // kStep: decay factor, in (0, 1]
};

// One stage of training.
struct TrainingStage {
  std::string name = "train";  // for progress, the log ("stage", multi-stage runs only), messages
  int steps = 1;               // optimiser steps of this stage, >= 1
  // Parameters the optimiser updates, as prefixes of torch::nn::Module::named_parameters() names
  // ("encoder" matches "encoder.convs.0.weight" but not "encoder2.bias"). Empty = every parameter
  // that is not frozen. Parameters not trained get requires_grad false during the stage.
  std::vector<std::string> trained;
  // Modules (prefixes of named_modules() names, same matching) whose parameters stay fixed and
  // that stay in eval mode throughout the stage, so their dropout and batch statistics do not move.
  // A frozen parameter is never trained, even when a `trained` prefix matches it.
  std::vector<std::string> frozen;
  OptimizerSpec optimizer;
  ScheduleSpec schedule;
};

// What a family may build its stages from: the run's TrainOptions (nn/training/train.h).
struct TrainStageDefaults {
  int steps = 10000;   // TrainOptions::steps: the run's total steps (on resume: the new total)
  double lr = 1e-3;    // TrainOptions::lr
  int warmup = 1000;   // TrainOptions::warmup
};

// The one stage of a family that does not declare its own: `defaults.steps` steps training every
// parameter with Adam (lr = defaults.lr, betas 0.9/0.999, eps 1e-8, no weight decay) and the
// Noam schedule with defaults.warmup: exactly the trainer's behaviour before stages existed.
inline TrainingStage default_training_stage(const TrainStageDefaults& defaults) {
  TrainingStage s;
  s.name = "train";
  s.steps = defaults.steps;
  s.optimizer.lr = defaults.lr;
  s.schedule.kind = ScheduleSpec::Kind::kNoam;
  s.schedule.warmup = defaults.warmup;
  return s;
}

// The Noam schedule value at a 1-based step: peak_lr * min(step / warmup, sqrt(warmup / step));
// warmup <= 0 gives peak_lr.
double noam_lr(double peak_lr, int warmup, int step);

// The learning rate of a stage at its 1-based step (1..total_steps) under `schedule`, peak_lr from
// the stage's optimiser.
double scheduled_lr(const ScheduleSpec& schedule, double peak_lr, int step, int total_steps);

// Throws mosyn::Error "<family>: stage '<name>': ..." when the list is empty, a name is empty or
// repeated, or a stage's steps, optimiser or schedule values are out of range. Whether prefixes
// match the model is checked by the trainer, which has the model.
void check_stages(const std::vector<TrainingStage>& stages, const std::string& family);

}  // namespace mosyn::nn
