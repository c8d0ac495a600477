// Typed reads of a model family's JSON config, with errors that name the family and the key,
// shared by every family's Options::from_json. Header-only; no LibTorch.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.h"

namespace mosyn::nn {

// log(2 pi), the Gaussian normalising constant per dimension (nats).
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

// config[key] as an integer; throws mosyn::Error "<family> config: '<key>' must be an integer".
inline int config_int(const nlohmann::json& config, const char* key, const char* family) {
  if (!config.at(key).is_number_integer())
    throw Error(std::string(family) + " config: '" + key + "' must be an integer");
  return config.at(key).get<int>();
}

// config[key] as a boolean; throws mosyn::Error "<family> config: '<key>' must be true or false".
inline bool config_bool(const nlohmann::json& config, const char* key, const char* family) {
  if (!config.at(key).is_boolean()) throw Error(std::string(family) + " config: '" + key + "' must be true or false");
  return config.at(key).get<bool>();
}

// config[key] as a number (integers accepted); throws mosyn::Error naming family and key.
inline double config_double(const nlohmann::json& config, const char* key, const char* family) {
  if (!config.at(key).is_number()) throw Error(std::string(family) + " config: '" + key + "' must be a number");
  return config.at(key).get<double>();
}

// config[key] as an array of integers >= 1 (e.g. channels per layer); throws mosyn::Error naming
// family and key.
inline std::vector<int> config_positive_ints(const nlohmann::json& config, const char* key, const char* family) {
  const auto& v = config.at(key);
  const std::string what = std::string(family) + " config: '" + key + "'";
  if (!v.is_array()) throw Error(what + " must be an array of integers");
  std::vector<int> out;
  for (const auto& e : v) {
    if (!e.is_number_integer()) throw Error(what + " must be an array of integers");
    out.push_back(e.get<int>());
    if (out.back() < 1) throw Error(what + " entries must be >= 1");
  }
  return out;
}

}  // namespace mosyn::nn
