// Locomotion along the held-out controls (set metrics, foot-locked) and the diversity of the N
// samples of one control.
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;
using detail::mean_finite;

// Each set metric over the N replicate sets (the set of the given clips' k-th samples), averaged,
// beside real_rows (the same clips' real metrics); only the rows `keep` accepts.
template <typename Keep>
void add_replicate_rows(EvalContext& ctx, const std::vector<std::vector<MotionPositions>>& per_clip,
                        const std::vector<size_t>& clips, const std::vector<MetricValue>& real_rows,
                        const std::string& key_prefix, const std::string& label_suffix, Keep keep, EvalResult& result) {
  std::vector<std::vector<double>> values(real_rows.size());
  for (int k = 0; k < ctx.num_samples(); ++k) {
    std::vector<MotionPositions> set;
    for (size_t i : clips) set.push_back(per_clip[i][k]);
    const auto rows = set_metrics(set, ctx.options().metrics);
    for (size_t r = 0; r < rows.size() && r < real_rows.size(); ++r) values[r].push_back(rows[r].value);
  }
  for (size_t r = 0; r < real_rows.size(); ++r)
    if (keep(real_rows[r].key))
      result.rows.push_back({key_prefix + real_rows[r].key, real_rows[r].label + label_suffix, mean_finite(values[r]),
                             real_rows[r].value});
}

// Every clip's rows (`key_prefix` + key).
void add_replicate_rows(EvalContext& ctx, const std::vector<std::vector<MotionPositions>>& per_clip,
                        const std::string& key_prefix, const std::string& label_suffix, EvalResult& result) {
  std::vector<size_t> all(per_clip.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  add_replicate_rows(ctx, per_clip, all, ctx.real_set_metrics(), key_prefix, label_suffix,
                     [](const std::string&) { return true; }, result);
}

// The footstep and skating rows per content (`locomotion.walk.footsteps.v_tol95_cmps`), model and
// real clips of that content alone: pooled over contents, a footstep tolerance mixes walks' with
// runs' (whose flight phases need a far larger one), so the per-content rows are the ones to
// compare against real clips of the same contents.
void add_per_content_rows(EvalContext& ctx, EvalResult& result) {
  const auto& labels = ctx.info().content_labels;
  for (size_t c = 0; c < labels.size(); ++c) {
    const std::vector<size_t> clips = ctx.clips_of_content(static_cast<int>(c));
    if (clips.empty()) continue;
    add_replicate_rows(ctx, ctx.samples(), clips, ctx.real_set_metrics(static_cast<int>(c)),
                       "locomotion." + labels[c] + ".", " (content " + labels[c] + ")", detail::is_gait_row, result);
  }
}

class LocomotionProtocol : public Protocol {
 public:
  std::string name() const override { return "locomotion"; }
  bool enabled(const EvalOptions&) const override { return true; }
  // Families that generate their root motion are placed on it (EvalContext::samples).
  bool applies_to(const nn::ModelTraits&) const override { return true; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    add_replicate_rows(ctx, ctx.samples(), "", "", result);
    add_per_content_rows(ctx, result);
    if (ctx.options().foot_lock) add_replicate_rows(ctx, ctx.foot_locked_samples(), "foot_locked.", " (foot-locked)", result);
  }
};

class DiversityProtocol : public Protocol {
 public:
  std::string name() const override { return "diversity"; }
  bool enabled(const EvalOptions&) const override { return true; }
  bool applies_to(const nn::ModelTraits&) const override { return true; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    const auto& samples = ctx.samples();
    std::vector<double> apd, spread;
    for (const auto& s : samples) {
      if (ctx.num_samples() < 2) break;
      std::vector<Eigen::MatrixXd> seqs;
      for (const auto& m : s) seqs.push_back(m.sequence());
      apd.push_back(average_pairwise_distance(seqs));
      spread.push_back(mean_pose_distance(seqs).mean_m.mean());
    }
    result.rows.push_back({"diversity.apd_m", "APD across the N samples of a control (m)", mean_finite(apd), kNaN});
    result.rows.push_back({"diversity.mean_pose_distance_m", "distance to the per-frame mean of the N samples (m)",
                           mean_finite(spread), kNaN});
    std::vector<Eigen::MatrixXd> seqs, real_seqs;
    for (const auto& s : samples)
      for (const auto& m : s) seqs.push_back(m.sequence());
    for (const auto& m : ctx.real()) real_seqs.push_back(m.sequence());
    result.rows.push_back(
        {"fse", "FSE: spectral entropy minus real data's (nats)", spectral_entropy_difference(seqs, real_seqs), 0.0});
  }
};

}  // namespace

std::unique_ptr<Protocol> make_locomotion_protocol() { return std::make_unique<LocomotionProtocol>(); }
std::unique_ptr<Protocol> make_diversity_protocol() { return std::make_unique<DiversityProtocol>(); }

}  // namespace mosyn::eval
