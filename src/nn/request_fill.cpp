#include "nn/request_fill.h"

#include <string>

#include "core/error.h"

namespace mosyn::nn {

torch::Tensor from_vector(const std::vector<float>& v, int64_t rows, int64_t cols) {
  return torch::from_blob(const_cast<float*>(v.data()), {rows, cols}, torch::kFloat32).clone();
}

torch::Device model_device(MotionModel& m) {
  auto params = m.parameters();
  return params.empty() ? torch::Device(torch::kCPU) : params.front().device();
}

namespace {

// Labels [b] from none, one label for all, or one per entry; checked against the run.
torch::Tensor label_tensor(const LoadedRun& run, const std::vector<int>& labels, int64_t b, int vocabulary,
                           const char* what) {
  if (!labels.empty() && labels.size() != 1 && static_cast<int64_t>(labels.size()) != b)
    throw Error(std::string(what) + " labels: give none, one, or one per character (" + std::to_string(b) + ")");
  std::vector<int64_t> ids(static_cast<size_t>(b), -1);
  for (int64_t i = 0; i < b && !labels.empty(); ++i) ids[i] = labels.size() == 1 ? labels[0] : labels[i];
  for (int64_t id : ids) {
    if (id == -1) continue;
    if (!run.traits.labels)
      throw Error(run.run_dir + ": this " + run.family + " model was trained without labels; a " + what +
                  " label needs a model trained with \"labels\": true");
    if (id < 0 || id >= vocabulary)
      throw Error(run.run_dir + ": " + what + " label " + std::to_string(id) + " is not in the model's vocabulary of " +
                  std::to_string(vocabulary));
  }
  return torch::tensor(ids, torch::kInt64);
}

}  // namespace

void fill_request(SampleRequest& req, const LoadedRun& run, const Standardiser& st, int64_t b,
                  const std::vector<float>& prefix_pose, const std::vector<float>& prefix_control,
                  const std::vector<int>& content, const std::vector<int>& style) {
  const int64_t d = run.context.pose_dim, c = run.context.control_dim;
  if (!prefix_pose.empty()) {
    if (!run.traits.prefix)
      throw Error(run.run_dir + ": this " + run.family + " model cannot continue a given motion (no prefix)");
    if (prefix_pose.size() % d != 0) throw Error("prefix pose is not [P, " + std::to_string(d) + "]");
    const int64_t p = static_cast<int64_t>(prefix_pose.size()) / d;
    req.prefix_pose = st.pose(from_vector(prefix_pose, p, d)).unsqueeze(0).expand({b, p, d}).contiguous();
    if (!prefix_control.empty()) {
      if (prefix_control.size() != static_cast<size_t>(p * c))
        throw Error("prefix control must be [" + std::to_string(p) + ", " + std::to_string(c) + "]");
      req.prefix_control = st.control(from_vector(prefix_control, p, c)).unsqueeze(0).expand({b, p, c}).contiguous();
    }
  }
  req.content = label_tensor(run, content, b, run.context.num_content, "content");
  req.style = label_tensor(run, style, b, run.context.num_style, "style");
  req.batch = static_cast<int>(b);
}

}  // namespace mosyn::nn
