// Offline sampling (sample_motions): raw <-> standardised features with the run's statistics around
// MotionModel::sample.
#include "nn/sampling.h"

#include <cmath>

#include <torch/types.h>
#include <torch/utils.h>

#include "core/error.h"
#include "core/trajectory.h"
#include "data/representation.h"
#include "nn/request_fill.h"
#include "nn/root_planting.h"
#include "nn/model.h"
#include "nn/standardiser.h"

namespace mosyn::nn {

namespace {

// control [T, C] raw, preceded by w rows of its first step (row 1; zeros when T < 2): the
// warm-up of SampleExtras::warmup_frames.
std::vector<float> with_lead_in(const std::vector<float>& control, int64_t c, int64_t w) {
  std::vector<float> first_step(static_cast<size_t>(c), 0.0f);
  if (static_cast<int64_t>(control.size()) >= 2 * c) first_step.assign(control.begin() + c, control.begin() + 2 * c);
  std::vector<float> out;
  out.reserve(static_cast<size_t>(w * c) + control.size());
  for (int64_t k = 0; k < w; ++k) out.insert(out.end(), first_step.begin(), first_step.end());
  out.insert(out.end(), control.begin(), control.end());
  return out;
}

}  // namespace

std::vector<SampledMotion> sample_motions(const LoadedRun& run, const std::vector<float>& control, int n,
                                          std::uint64_t seed, double temperature, const SampleExtras& extras) {
  if (!run.model)
    throw Error(run.run_dir + ": the " + run.family + " family does not generate motion (it scores motions: use it with "
                "mosyn eval --classifier)");
  if (n < 1) throw Error("sample_motions: n must be >= 1");
  const int64_t d = run.context.pose_dim, c = run.context.control_dim;
  if (control.empty() || control.size() % c != 0)
    throw Error("sample_motions: control is not [T, " + std::to_string(c) + "]");
  if (extras.warmup_frames < 0 && extras.warmup_frames != kFamilyWarmup)
    throw Error("sample_motions: warmup_frames must be >= 0 or kFamilyWarmup");
  const int64_t t = static_cast<int64_t>(control.size()) / c;
  int64_t w = extras.warmup_frames;
  if (w == kFamilyWarmup) w = std::lround(run.traits.default_warmup_s * run.dataset.fps);
  // The real prefix is the start; a family that makes its own root motion takes no control lead-in.
  if (!extras.prefix_pose.empty() || run.traits.control != InputUse::kTakes) w = 0;
  std::vector<float> full_control = with_lead_in(control, c, w);
  Standardiser st(run.stats);
  auto& model = *run.model;
  const auto device = model_device(model);
  SampleRequest req;
  req.control =
      st.control(from_vector(full_control, w + t, c)).unsqueeze(0).expand({n, w + t, c}).contiguous().to(device);
  fill_request(req, run, st, n, extras.prefix_pose, extras.prefix_control, {extras.content}, {extras.style});
  if (req.prefix_pose.defined()) req.prefix_pose = req.prefix_pose.to(device);
  if (req.prefix_control.defined()) req.prefix_control = req.prefix_control.to(device);
  req.content = req.content.to(device);
  req.style = req.style.to(device);
  req.temperature = temperature;
  req.seed = seed;
  model.eval();
  const SampleOutput out = model.sample(req);
  const auto poses = st.unpose(out.pose.narrow(1, w, t).to(torch::kCPU, torch::kFloat32)).contiguous();
  std::vector<SampledMotion> result(n);
  if (run.traits.control == InputUse::kTakes) {  // exactly the caller's control, not a round trip
    for (auto& r : result) r.control = control;
  } else {
    const auto controls = st.uncontrol(out.control.narrow(1, w, t).to(torch::kCPU, torch::kFloat32)).contiguous();
    for (int i = 0; i < n; ++i) {
      const float* p = controls[i].data_ptr<float>();
      result[i].control.assign(p, p + t * c);
    }
  }
  for (int i = 0; i < n; ++i) {
    const float* p = poses[i].data_ptr<float>();
    result[i].pose.assign(p, p + t * d);
  }
  if (plants_root(run, extras.raw_root))
    for (auto& m : result) plant_root(run, extras.prefix_pose, &m);
  return result;
}

}  // namespace mosyn::nn
