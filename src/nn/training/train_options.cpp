// TrainOptions as JSON (config.json "train", train-config.json files) through one field list, and
// the named training presets.
#include <cstdint>
#include <string>

#include "core/error.h"
#include "nn/label_pattern.h"
#include "nn/options_fields.h"
#include "nn/registry.h"
#include "nn/training/train.h"

namespace mosyn::nn {

namespace {

FieldCheck<std::map<std::string, double>> label_factors() {
  return {[](const std::string& key, const std::map<std::string, double>& factors) {
            for (const auto& [pattern, factor] : factors)
              if (std::string problem = label_factor_problem(pattern, factor, key, /*zero_allowed=*/false);
                  !problem.empty())
                return problem;
            return std::string();
          },
          ""};
}

// Presets every family takes (a family's own, FamilyInfo::train_presets, come after these).
const std::map<std::string, nlohmann::json>& generic_presets() {
  static const std::map<std::string, nlohmann::json> presets = {
      // What `make test` runs the recipes with (SMOKE=1): every stage for a handful of steps on a few
      // windows, checkpointed and validated, so that a recipe that would fail, fails in seconds.
      {"smoke",
       {{"steps", 2}, {"batch", 4}, {"warmup", 1}, {"val_windows", 8}, {"checkpoint_every", 1},
        {"validate_every", 2}, {"log_every", 1}}},
      // Continuing a trained model (--init-from): a lower peak rate with a short warm-up, since Adam
      // starts afresh on weights that are already good, and every 100 steps kept and validated,
      // because continued training can pass its best point within a few hundred steps
      // (docs/experiments.md).
      {"finetune",
       {{"lr", 2e-4}, {"warmup", 100}, {"checkpoint_every", 100}, {"validate_every", 100},
        {"keep_checkpoints", true}}},
  };
  return presets;
}

}  // namespace

const OptionFields<TrainOptions>& TrainOptions::fields() {
  using T = TrainOptions;
  static const auto f =
      OptionFields<T>("training")
          .ignore("preset")  // resolved first, by from_json
          .field("data_dir", &T::data_dir, "prepared dataset directory")
          .field("out_dir", &T::out_dir, "run directory")
          .field("model_config", &T::model_config, "overrides of the family's model defaults")
          .field("steps", &T::steps, "total optimiser steps", at_least(1))
          .field("batch", &T::batch, "windows per batch (global over data-parallel ranks)", at_least(1))
          .field("window", &T::window, "frames per window; 0 = the dataset's", at_least(0))
          .field("window_sampling", &T::window_sampling, "how windows are drawn", one_of({"windows", "frames"}))
          .field("speed_balance", &T::speed_balance, "flattening of the draws over mean root speed",
                 in_range(0.0, 1.0))
          .field("label_weights", &T::label_weights, "draw factors per CONTENT:STYLE pattern", label_factors())
          .written_if([](const T& o) { return !o.label_weights.empty(); })
          .field("lr", &T::lr, "peak learning rate (Adam)", above_up_to(0.0, 1e3))
          .field("warmup", &T::warmup, "Noam warm-up steps; 0 = constant rate", at_least(0))
          .field("grad_clip", &T::grad_clip, "largest global gradient norm; <= 0 = no clipping")
          .field("seed", &T::seed, "seed of initialisation, data order and dropout")
          .field("threads", &T::threads, "CPU threads; 0 = all cores", at_least(0))
          .field("device", &T::device, "cpu, cuda or cuda:N")
          .field("resume", &T::resume, "continue the run where its checkpoint ended")
          .written_if([](const T&) { return false; })  // a way to start, not a property of the run
          .field("overwrite", &T::overwrite, "replace an existing run")
          .written_if([](const T&) { return false; })
          .field("checkpoint_every", &T::checkpoint_every, "steps between checkpoints", at_least(1))
          .field("keep_checkpoints", &T::keep_checkpoints, "also keep checkpoint-STEP.pt")
          .written_if([](const T& o) { return o.keep_checkpoints; })
          .field("validate_every", &T::validate_every, "steps between validations; 0 = never", at_least(0))
          .field("val_windows", &T::val_windows, "windows of the fixed validation subset", at_least(1))
          .field("log_every", &T::log_every, "steps between progress reports", at_least(1))
          .field("init_from", &T::init_from, "warm start from this run or model directory");
  return f;
}

nlohmann::json TrainOptions::to_json() const {
  nlohmann::json j = fields().write(*this);
  j["family"] = family;
  if (!preset.empty()) j["preset"] = preset;  // where the values began; they are all written too
  return j;
}

TrainOptions TrainOptions::from_json(const nlohmann::json& j) {
  if (!j.is_object()) throw Error("training config must be a JSON object");
  TrainOptions o;
  if (j.contains("family")) {
    if (!j["family"].is_string()) throw Error("training config: 'family' must be a string");
    o.family = j["family"].get<std::string>();
  }
  if (j.contains("preset")) {
    if (!j["preset"].is_string()) throw Error("training config: 'preset' must be a string");
    o.preset = j["preset"].get<std::string>();
    fields().read(train_preset(o.family, o.preset), &o);
  }
  fields().read(j, &o);
  fields().check(o);
  return o;
}

std::vector<std::string> train_preset_names(const std::string& family) {
  std::vector<std::string> names;
  for (const auto& [name, preset] : generic_presets()) names.push_back(name);
  if (!family.empty())
    for (const auto& [name, preset] : family_info(family).train_presets) names.push_back(name);
  return names;
}

nlohmann::json train_preset(const std::string& family, const std::string& name) {
  const auto& generic = generic_presets();
  if (auto it = generic.find(name); it != generic.end()) return it->second;
  if (!family.empty()) {
    const FamilyInfo info = family_info(family);
    if (auto it = info.train_presets.find(name); it != info.train_presets.end()) return it->second;
  }
  std::string known;
  for (const std::string& n : train_preset_names(family)) known += (known.empty() ? "" : ", ") + n;
  throw Error("unknown training preset '" + name + "'" + (family.empty() ? "" : " for " + family) + " (known: " +
              known + ")");
}

TrainStageDefaults stage_defaults(const TrainOptions& options) {
  TrainStageDefaults d;
  d.steps = options.steps;
  d.lr = options.lr;
  d.warmup = options.warmup;
  return d;
}

}  // namespace mosyn::nn
