// Joint-position errors against the held-out clip itself (Habibie et al. 2017, Tables 1-2).
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;
using detail::root_relative;

// The error frames converted by time to the dataset's rate; throws for invalid options.
std::vector<int> frames_at_dataset_rate(const EvalOptions& o, double fps) {
  if (!(o.error_frames_fps > 0)) throw Error("evaluate: error_frames_fps must be > 0");
  if (o.initial_frames < 1) throw Error("evaluate: initial_frames must be >= 1");
  std::vector<int> frames;
  for (int f : o.error_frames) {
    if (f < 0) throw Error("evaluate: error frames must be >= 0");
    frames.push_back(static_cast<int>(std::lround(f / o.error_frames_fps * fps)));
  }
  const int last = *std::max_element(frames.begin(), frames.end());
  if (last < o.initial_frames)
    throw Error("evaluate: every error frame lies inside the " + std::to_string(o.initial_frames) + " initial frames");
  return frames;
}

class JointErrorsProtocol : public Protocol {
 public:
  std::string name() const override { return "joint_errors"; }
  bool enabled(const EvalOptions& o) const override { return o.joint_errors && !o.error_frames.empty(); }
  // The initial-frames setting continues real frames, and both compare with the clip along its own
  // control: families that generate their root motion walk elsewhere.
  bool applies_to(const nn::ModelTraits& t) const override { return t.control == nn::InputUse::kTakes && t.prefix; }
  void run(EvalContext& ctx, EvalResult& result) const override;
};

void JointErrorsProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const EvalOptions& o = ctx.options();
  const std::vector<int> frames = frames_at_dataset_rate(o, ctx.info().fps);
  const int last = *std::max_element(frames.begin(), frames.end());
  const size_t nf = frames.size();
  const int n = ctx.num_samples();
  // [setting][frame] sums over clips x samples; settings: motion/pose x prior/initial.
  std::vector<std::vector<double>> sums(4, std::vector<double>(nf, 0.0));
  // Adds the errors of one sample against the clip (world and pelvis-relative sequences).
  auto accumulate = [&](int setting, const Eigen::MatrixXd& sample, const Eigen::MatrixXd& truth,
                        const Eigen::MatrixXd& truth_relative) {
    const auto motion = joint_position_errors_m(sample, truth, frames);
    const auto pose = joint_position_errors_m(root_relative(sample), truth_relative, frames);
    for (size_t k = 0; k < nf; ++k) {
      sums[setting][k] += motion[k];
      sums[setting + 1][k] += pose[k];
    }
  };
  const auto& samples = ctx.samples();
  int count = 0;
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    ctx.report("joint errors", static_cast<int>(i), static_cast<int>(ctx.num_clips()));
    const data::ClipRecord& rec = ctx.clip(i);
    if (rec.num_frames <= last) continue;
    const Eigen::MatrixXd truth = ctx.real()[i].sequence(), truth_relative = root_relative(truth);
    for (const auto& m : samples[i]) accumulate(0, m.sequence(), truth, truth_relative);
    for (const auto& s : ctx.continuations(i, o.initial_frames, rec.num_frames, o.seed + 2000003 + i))
      accumulate(2, s, truth, truth_relative);
    ++count;
  }
  result.joint_error_clips = count;
  const char* names[4] = {"motion_prior", "pose_prior", "motion_initial", "pose_initial"};
  const std::string what[4] = {"motion error, prior sample", "pose error (root-relative), prior sample",
                               "motion error, " + std::to_string(o.initial_frames) + " initial frames",
                               "pose error (root-relative), " + std::to_string(o.initial_frames) + " initial frames"};
  for (int s = 0; s < 4; ++s)
    for (size_t k = 0; k < nf; ++k) {
      char at[64];
      std::snprintf(at, sizeof at, " at %.2f s (cm)", o.error_frames[k] / o.error_frames_fps);
      result.rows.push_back({std::string("joint_error.") + names[s] + ".f" + std::to_string(o.error_frames[k]),
                             what[s] + at, count > 0 ? 100.0 * sums[s][k] / (count * n) : kNaN, kNaN});
    }
}

}  // namespace

std::unique_ptr<Protocol> make_joint_errors_protocol() { return std::make_unique<JointErrorsProtocol>(); }

}  // namespace mosyn::eval
