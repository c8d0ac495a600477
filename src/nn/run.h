// Loading a trained run directory (see nn/training/train.h for its files) with no architecture
// flags: family, model config and data description all come from config.json.
#pragma once

#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/root_planting.h"

#include "data/dataset.h"
#include "nn/context.h"
#include "nn/registry.h"
#include "nn/traits.h"

namespace mosyn::nn {

class MotionModel;
class TrainableModel;

struct LoadOptions {
  std::string checkpoint = "checkpoint.pt";  // file inside the run dir, e.g. "best.pt"
  std::string device = "cpu";
  int threads = 0;  // LibTorch CPU threads; 0 = all cores, < 0 = leave as is
  // Leave LoadedRun::root_planting empty even when config.json has one (still checked): the model's
  // own root steps, for comparing them with the planted ones (`--raw-root`).
  bool raw_root = false;
};

struct LoadedRun {
  std::string run_dir;
  std::string family;
  nlohmann::json config;            // the whole config.json
  ModelContext context;
  data::DatasetInfo dataset;        // skeleton, layout, fps, labels of the training data
  data::DatasetStats stats;         // standardisation statistics
  FamilyKind kind = FamilyKind::kMotion;
  std::shared_ptr<TrainableModel> trainable;  // the model, in eval mode, on the requested device
  std::shared_ptr<MotionModel> model;  // the same when it generates motion (kind kMotion), else null
  ModelTraits traits;               // model->traits() (default for classifiers), without LibTorch headers
  int step = 0;                     // optimiser steps of the loaded checkpoint
  // config.json's "root_planting" (nn/root_planting.h): how sampling plants the root steps of a
  // family that makes its own root motion; nullopt keeps the model's own steps.
  std::optional<RootPlantingOptions> root_planting;
};

// Throws mosyn::Error naming the file when config.json, stats.json or the checkpoint is missing,
// truncated, corrupt or does not match the config.
LoadedRun load_run(const std::string& run_dir, const LoadOptions& options = {});

}  // namespace mosyn::nn
