// The registry of model families. Each family folder (src/nn/<family>/) registers itself with
// MOSYN_REGISTER_FAMILY in one of its sources; its CMake target is linked into every program
// through the mosyn_families target (see src/nn/README.md). Nothing outside a family's folder
// names the family.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nn/context.h"

namespace mosyn::nn {

class TrainableModel;

// What a family is for.
enum class FamilyKind {
  kMotion,      // generates motion: a MotionModel (nn/model.h)
  kClassifier,  // recognises content / style labels (nn/classifier/classifier.h), for evaluation
};

using FamilyFactory =
    std::function<std::shared_ptr<TrainableModel>(const nlohmann::json& config, const ModelContext& context)>;

struct FamilyInfo {
  std::string name;          // e.g. "moglow": `mosyn train <name>`, config.json "family"
  FamilyKind kind = FamilyKind::kMotion;
  std::string summary;       // one line for `mosyn train --help`, e.g. "MoGlow (Henter et al. 2020)"
  FamilyFactory factory;     // builds the model from a (partial) config and the data's context
  // A config small enough to train in seconds on the project's synthetic motion: used by the
  // conformance test that runs over every registered family and by the tiny test models.
  nlohmann::json tiny_config = nlohmann::json::object();
  // Named training presets of this family (nn/training/train.h train_preset): name -> the
  // TrainOptions keys it sets, e.g. "paper" -> its paper's batch, learning rate and schedule.
  std::map<std::string, nlohmann::json> train_presets;
};

// Adds a family (replacing one of the same name). Thread-safe.
void register_family(FamilyInfo info);

// The registered family of this name; throws mosyn::Error naming the known ones when absent.
FamilyInfo family_info(const std::string& name);

// Names of every registered family (motion models and classifiers), sorted.
std::vector<std::string> model_families();
// Names of the registered families of one kind, sorted.
std::vector<std::string> families_of_kind(FamilyKind kind);

// Builds a model of any registered family from a (possibly partial) config; missing keys take the
// family's defaults. Throws mosyn::Error for an unknown family, unknown key or invalid value.
std::shared_ptr<TrainableModel> create_trainable(const std::string& family, const nlohmann::json& config,
                                                 const ModelContext& context);

namespace detail {
struct FamilyRegistration {
  explicit FamilyRegistration(FamilyInfo info) { register_family(std::move(info)); }
};
}  // namespace detail

}  // namespace mosyn::nn

// Registers a family when the program starts: MOSYN_REGISTER_FAMILY(moglow, FamilyInfo{...}).
// The token names the static registration object and the function mosyn_families' generated
// source calls, which keeps the family's object file in the link (a static library member that no
// one references would be dropped).
#define MOSYN_REGISTER_FAMILY(token, ...)                                                  \
  namespace mosyn::nn::registered {                                                      \
  static const ::mosyn::nn::detail::FamilyRegistration token##_registration{__VA_ARGS__}; \
  }                                                                                      \
  void mosyn_family_##token##_linked() {}
