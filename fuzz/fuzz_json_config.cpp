// libFuzzer harness: JSON text (io/json_file.h) read as the configuration-like files of a dataset
// (dataset.json description, stats.json, skeleton and feature layout).
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"
#include "data/dataset.h"
#include "fuzz_check.h"
#include "io/json_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace mosyn;
  const std::string text(reinterpret_cast<const char*>(data), size);
  nlohmann::json j;
  try {
    j = io::parse_json(text, "fuzz.json");
  } catch (const Error&) {
    return 0;
  }
  try {
    const data::DatasetInfo info = data::info_from_json(j, "fuzz.json");
    // What is accepted writes back and reads back the same.
    const data::DatasetInfo again = data::info_from_json(data::info_to_json(info), "again.json");
    FUZZ_CHECK(again.layout.pose_dim == info.layout.pose_dim);
    FUZZ_CHECK(again.skeleton.joint_names == info.skeleton.joint_names);
  } catch (const Error&) {
  }
  try {
    const data::DatasetStats stats = data::stats_from_json(j, "fuzz.json");
    const data::DatasetStats again = data::stats_from_json(data::stats_to_json(stats), "again.json");
    FUZZ_CHECK(again.pose_mean == stats.pose_mean && again.pose_constant == stats.pose_constant);
  } catch (const Error&) {
  }
  for (const char* key : {"skeleton", "layout"}) {
    if (!j.is_object() || !j.contains(key)) continue;
    try {
      if (std::string(key) == "skeleton") data::skeleton_from_json(j[key], "fuzz.json");
      else data::layout_from_json(j[key], "fuzz.json");
    } catch (const Error&) {
    }
  }
  return 0;
}
