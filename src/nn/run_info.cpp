#include "nn/run_info.h"

#include "core/error.h"
#include "io/json_number.h"

namespace mosyn::nn {

nlohmann::json context_to_json(const ModelContext& c) {
  return {{"pose_dim", c.pose_dim},       {"control_dim", c.control_dim}, {"num_content", c.num_content},
          {"num_style", c.num_style},     {"fps", c.fps},                 {"pose_form", data::to_string(c.pose_form)}};
}

ModelContext context_from_json(const nlohmann::json& j, const std::string& what) {
  try {
    ModelContext c;
    c.pose_dim = io::json_get<int>(j.at("pose_dim"));
    c.control_dim = io::json_get<int>(j.at("control_dim"));
    c.num_content = io::json_get<int>(j.at("num_content"));
    c.num_style = io::json_get<int>(j.at("num_style"));
    c.fps = j.at("fps").get<double>();
    c.pose_form = data::parse_pose_form(j.at("pose_form").get<std::string>());
    return c;
  } catch (const std::exception& e) {
    throw Error(what + ": malformed model context: " + e.what());
  }
}

ModelContext context_for(const data::DatasetInfo& info, const data::DatasetStats& stats) {
  ModelContext c;
  c.pose_dim = info.layout.pose_dim;
  c.control_dim = info.layout.control_dim;
  c.num_content = static_cast<int>(info.content_labels.size());
  c.num_style = static_cast<int>(info.style_labels.size());
  c.fps = info.fps;
  c.pose_form = info.layout.form;
  c.skeleton = info.skeleton;
  c.layout = info.layout;
  c.stats = stats;
  c.content_labels = info.content_labels;
  c.style_labels = info.style_labels;
  return c;
}

}  // namespace mosyn::nn
