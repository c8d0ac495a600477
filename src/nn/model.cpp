#include "nn/model.h"

#include <torch/cuda.h>
#include <torch/utils.h>

#include <algorithm>
#include <mutex>
#include <thread>

#include "core/error.h"
#include "nn/classifier/classifier.h"
#include "nn/moglow/moglow.h"
#include "nn/rvae/rvae.h"

namespace mosyn::nn {

std::unique_ptr<StreamState> MotionModel::begin_stream(const SampleRequest&) {
  throw Error("model family '" + family() + "' cannot generate frame by frame (not causal)");
}

torch::Tensor MotionModel::step_stream(StreamState&, const torch::Tensor&) {
  throw Error("model family '" + family() + "' cannot generate frame by frame (not causal)");
}

namespace {

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

// Built-in families are listed here explicitly: self-registering statics in a static library
// would be dropped by the linker.
std::map<std::string, ModelFactory>& registry() {
  static std::map<std::string, ModelFactory> r = {
      {"classifier", [](const nlohmann::json& c, const ModelContext& ctx) -> std::shared_ptr<MotionModel> {
         return make_classifier(c, ctx);
       }},
      {"moglow", [](const nlohmann::json& c, const ModelContext& ctx) -> std::shared_ptr<MotionModel> {
         return make_moglow(c, ctx);
       }},
      {"rvae", [](const nlohmann::json& c, const ModelContext& ctx) -> std::shared_ptr<MotionModel> {
         return make_rvae(c, ctx);
       }},
  };
  return r;
}

}  // namespace

std::shared_ptr<MotionModel> create_model(const std::string& family, const nlohmann::json& config,
                                          const ModelContext& context) {
  ModelFactory factory;
  {
    std::lock_guard<std::mutex> lock(registry_mutex());
    auto it = registry().find(family);
    if (it == registry().end()) {
      std::string known;
      for (const auto& kv : registry()) known += (known.empty() ? "" : ", ") + kv.first;
      throw Error("unknown model family '" + family + "' (known: " + known + ")");
    }
    factory = it->second;
  }
  if (context.pose_dim <= 0) throw Error("create_model: pose_dim must be positive");
  if (context.control_dim <= 0) throw Error("create_model: control_dim must be positive");
  return factory(config.is_null() ? nlohmann::json::object() : config, context);
}

std::vector<std::string> model_families() {
  std::lock_guard<std::mutex> lock(registry_mutex());
  std::vector<std::string> names;
  for (const auto& kv : registry()) names.push_back(kv.first);
  return names;
}

void register_model_family(const std::string& family, ModelFactory factory) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  registry()[family] = std::move(factory);
}

int set_num_threads(int threads) {
  if (threads <= 0) threads = std::max(1u, std::thread::hardware_concurrency());
  torch::set_num_threads(threads);
  return threads;
}

torch::Device parse_device(const std::string& device) {
  if (device.empty() || device == "cpu") return torch::Device(torch::kCPU);
  if (device.rfind("cuda", 0) == 0) {
    if (!torch::cuda::is_available()) throw Error("device '" + device + "' requested but CUDA is not available");
    try {
      return torch::Device(device);
    } catch (const std::exception&) {
      throw Error("invalid device '" + device + "'");
    }
  }
  throw Error("invalid device '" + device + "' (expected cpu, cuda or cuda:N)");
}

}  // namespace mosyn::nn
