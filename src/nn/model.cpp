#include "nn/model.h"

#include <torch/cuda.h>
#include <torch/utils.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <thread>

#include "core/error.h"

namespace mosyn::nn {

const char* to_string(InputUse use) {
  switch (use) {
    case InputUse::kIgnores: return "ignores";
    case InputUse::kTakes: return "takes";
    case InputUse::kGenerates: return "generates";
  }
  return "?";
}

std::unique_ptr<StreamState> MotionModel::begin_stream(const SampleRequest&) {
  throw Error("model family '" + family() + "' cannot generate frame by frame (not causal)");
}

StreamFrame MotionModel::step_stream(StreamState&, const torch::Tensor&) {
  throw Error("model family '" + family() + "' cannot generate frame by frame (not causal)");
}

StreamFrame MotionModel::step_stream_ahead(StreamState& state, const torch::Tensor& control, const torch::Tensor&) {
  return step_stream(state, control);
}

void MotionModel::copy_stream_row(StreamState&, int64_t, const StreamState&, int64_t) {
  throw Error("model family '" + family() + "' cannot move one character between streams (its batch is one state)");
}

void MotionModel::reseed_stream_row(StreamState&, int64_t, std::uint64_t) {
  throw Error("model family '" + family() + "' has no per-character noise generators to reseed");
}

std::uint64_t row_seed(std::uint64_t seed, int64_t row) {
  if (row == 0) return seed;
  // splitmix64 of the pair: nearby seeds and rows give unrelated streams.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(row + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

namespace {

std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}

// Filled by the families' static registrations before main (construct on first use, so the order
// of static initialisation across object files does not matter).
std::map<std::string, FamilyInfo>& registry() {
  static std::map<std::string, FamilyInfo> r;
  return r;
}

std::string known_families() {
  std::string known;
  for (const auto& kv : registry()) known += (known.empty() ? "" : ", ") + kv.first;
  return known.empty() ? "none: the program does not link the mosyn_families target" : known;
}

}  // namespace

void register_family(FamilyInfo info) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  const std::string name = info.name;
  registry()[name] = std::move(info);
}

FamilyInfo family_info(const std::string& name) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  auto it = registry().find(name);
  if (it == registry().end()) throw Error("unknown model family '" + name + "' (known: " + known_families() + ")");
  return it->second;
}

std::vector<std::string> model_families() {
  std::lock_guard<std::mutex> lock(registry_mutex());
  std::vector<std::string> names;
  for (const auto& kv : registry()) names.push_back(kv.first);
  return names;
}

std::vector<std::string> families_of_kind(FamilyKind kind) {
  std::lock_guard<std::mutex> lock(registry_mutex());
  std::vector<std::string> names;
  for (const auto& kv : registry())
    if (kv.second.kind == kind) names.push_back(kv.first);
  return names;
}

std::shared_ptr<TrainableModel> create_trainable(const std::string& family, const nlohmann::json& config,
                                                 const ModelContext& context) {
  const FamilyInfo info = family_info(family);
  if (context.pose_dim <= 0) throw Error("create_model: pose_dim must be positive");
  if (context.control_dim <= 0) throw Error("create_model: control_dim must be positive");
  return info.factory(config.is_null() ? nlohmann::json::object() : config, context);
}

std::shared_ptr<MotionModel> create_model(const std::string& family, const nlohmann::json& config,
                                          const ModelContext& context) {
  if (family_info(family).kind != FamilyKind::kMotion)
    throw Error("model family '" + family + "' does not generate motion");
  return std::dynamic_pointer_cast<MotionModel>(create_trainable(family, config, context));
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
