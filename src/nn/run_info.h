// JSON form of ModelContext for run directories. No LibTorch here.
#pragma once

#include <nlohmann/json.hpp>

#include "data/dataset.h"
#include "nn/context.h"

namespace mosyn::nn {

// Dataset descriptions and statistics use data::info_to_json / data::stats_to_json.
nlohmann::json context_to_json(const ModelContext& context);
ModelContext context_from_json(const nlohmann::json& j, const std::string& what);

// The model context a dataset implies (dims, label counts, fps, pose form, skeleton, layout and
// statistics).
ModelContext context_for(const data::DatasetInfo& info, const data::DatasetStats& stats);

}  // namespace mosyn::nn
