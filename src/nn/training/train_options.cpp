// TrainOptions as JSON (config.json "train", train-config.json files).
#include <cstdint>
#include <string>

#include "core/error.h"
#include "io/json_number.h"
#include "nn/label_pattern.h"
#include "nn/training/train.h"

namespace mosyn::nn {

nlohmann::json TrainOptions::to_json() const {
  nlohmann::json j = {{"family", family},
          {"data_dir", data_dir},
          {"out_dir", out_dir},
          {"model_config", model_config},
          {"steps", steps},
          {"batch", batch},
          {"window", window},
          {"window_sampling", window_sampling},
          {"speed_balance", speed_balance},
          {"lr", lr},
          {"warmup", warmup},
          {"grad_clip", grad_clip},
          {"seed", seed},
          {"threads", threads},
          {"device", device},
          {"checkpoint_every", checkpoint_every},
          {"validate_every", validate_every},
          {"val_windows", val_windows},
          {"log_every", log_every},
          {"init_from", init_from}};
  // Written only when set, so configs of runs made before the option stay as they were.
  if (!label_weights.empty()) j["label_weights"] = label_weights;
  if (keep_checkpoints) j["keep_checkpoints"] = true;
  return j;
}

TrainOptions TrainOptions::from_json(const nlohmann::json& j) {
  TrainOptions o;
  try {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const auto& k = it.key();
      const auto& v = it.value();
      if (k == "family") o.family = v.get<std::string>();
      else if (k == "data_dir") o.data_dir = v.get<std::string>();
      else if (k == "out_dir") o.out_dir = v.get<std::string>();
      else if (k == "model_config") o.model_config = v;
      else if (k == "steps") o.steps = io::json_get<int>(v);
      else if (k == "batch") o.batch = io::json_get<int>(v);
      else if (k == "window") o.window = io::json_get<int>(v);
      else if (k == "window_sampling") o.window_sampling = v.get<std::string>();
      else if (k == "speed_balance") o.speed_balance = v.get<double>();
      else if (k == "label_weights") o.label_weights = v.get<std::map<std::string, double>>();
      else if (k == "lr") o.lr = v.get<double>();
      else if (k == "warmup") o.warmup = io::json_get<int>(v);
      else if (k == "grad_clip") o.grad_clip = v.get<double>();
      else if (k == "seed") o.seed = io::json_get<std::uint64_t>(v);
      else if (k == "threads") o.threads = io::json_get<int>(v);
      else if (k == "device") o.device = v.get<std::string>();
      else if (k == "resume") o.resume = v.get<bool>();
      else if (k == "overwrite") o.overwrite = v.get<bool>();
      else if (k == "checkpoint_every") o.checkpoint_every = io::json_get<int>(v);
      else if (k == "keep_checkpoints") o.keep_checkpoints = v.get<bool>();
      else if (k == "validate_every") o.validate_every = io::json_get<int>(v);
      else if (k == "val_windows") o.val_windows = io::json_get<int>(v);
      else if (k == "log_every") o.log_every = io::json_get<int>(v);
      else if (k == "init_from") o.init_from = v.get<std::string>();
      else throw Error("unknown training option '" + k + "'");
    }
    if (o.window_sampling != "windows" && o.window_sampling != "frames")
      throw Error("window_sampling must be \"windows\" or \"frames\", got \"" + o.window_sampling + "\"");
    if (!(o.speed_balance >= 0 && o.speed_balance <= 1))
      throw Error("speed_balance must lie in [0, 1], got " + std::to_string(o.speed_balance));
    for (const auto& [key, factor] : o.label_weights)
      if (const std::string problem = label_factor_problem(key, factor, "label_weights", /*zero_allowed=*/false);
          !problem.empty())
        throw Error(problem);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(std::string("bad training option: ") + e.what());
  }
  return o;
}

TrainStageDefaults stage_defaults(const TrainOptions& options) {
  TrainStageDefaults d;
  d.steps = options.steps;
  d.lr = options.lr;
  d.warmup = options.warmup;
  return d;
}

}  // namespace mosyn::nn
