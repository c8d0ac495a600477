// Generation by label alone (Ghorbani et al. 2020, section 5.2, Table 2): K samples for every
// combination of the run's content and style labels, no prefix (families that take control walk
// the long-horizon meander), scored by an evaluation classifier beside the held-out clips: the
// Inception score of the content and of the style heads, the FID of all samples and per requested
// content and per requested style, and how often the request is recognised.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "eval/protocols/protocols.h"
#include "nn/classifier/classify.h"
#include "nn/sample_job.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;

// Classifier inputs with the classifier's label ids (-1 = none) of the samples or the real clips.
struct LabelledSet {
  std::vector<std::vector<float>> poses, controls;
  std::vector<int> content, style;
};

// Rows of a [N, cols] float matrix whose label equals `label`, as Eigen.
Eigen::MatrixXd rows_with(const std::vector<float>& values, int cols, const std::vector<int>& labels, int label) {
  std::vector<int> keep;
  for (size_t i = 0; i < labels.size(); ++i)
    if (label < 0 || labels[i] == label) keep.push_back(static_cast<int>(i));
  Eigen::MatrixXd m(static_cast<Eigen::Index>(keep.size()), cols);
  for (size_t r = 0; r < keep.size(); ++r)
    for (int c = 0; c < cols; ++c) m(static_cast<Eigen::Index>(r), c) = values[static_cast<size_t>(keep[r]) * cols + c];
  return m;
}

// FID between two feature sets; NaN when either has fewer than 4 rows (no usable covariance).
double fid_or_nan(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() >= 4 && b.rows() >= 4 ? frechet_inception_distance(a, b) : kNaN;
}

// Percentage of rows whose arg-max is their label (label -1 skipped); NaN when none.
double recognised_percent(const std::vector<float>& probs, int k, const std::vector<int>& labels) {
  int right = 0, total = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] < 0) continue;
    const float* row = probs.data() + i * k;
    right += static_cast<int>(std::max_element(row, row + k) - row) == labels[i];
    ++total;
  }
  return total > 0 ? 100.0 * right / total : kNaN;
}

class LabelGenerationProtocol : public Protocol {
 public:
  std::string name() const override { return "label_generation"; }
  bool enabled(const EvalOptions& o) const override { return o.label_samples > 0 && !o.classifier_dir.empty(); }
  bool applies_to(const nn::ModelTraits& t) const override { return t.labels; }
  void run(EvalContext& ctx, EvalResult& result) const override;

 private:
  LabelledSet sample_every_combination(EvalContext& ctx, const nn::LoadedRun& cls) const;
  LabelledSet real_clips(const EvalContext& ctx, const nn::LoadedRun& cls) const;
};

LabelledSet LabelGenerationProtocol::sample_every_combination(EvalContext& ctx, const nn::LoadedRun& cls) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  const double seconds = o.label_seconds > 0 ? o.label_seconds : ctx.info().window_frames / run.dataset.fps;
  const std::vector<float> control = detail::long_horizon_control(run, seconds);
  const auto& contents = run.dataset.content_labels;
  const auto& styles = run.dataset.style_labels;
  const int num_styles = std::max<int>(1, static_cast<int>(styles.size()));
  const int combinations = std::max<int>(1, static_cast<int>(contents.size())) * num_styles;
  LabelledSet set;
  for (int k = 0; k < combinations; ++k) {
    ctx.report("label generation", k, combinations);
    nn::SampleExtras extras;
    extras.content = contents.empty() ? -1 : k / num_styles;
    extras.style = styles.empty() ? -1 : k % num_styles;
    const auto motions = nn::sample_motions(run, control, o.label_samples, o.seed + 9000001 + 1000 * k, o.temperature,
                                            extras);
    const int ci = nn::translate_label(extras.content, contents, cls.dataset.content_labels);
    const int si = nn::translate_label(extras.style, styles, cls.dataset.style_labels);
    for (size_t n = 0; n < motions.size(); ++n) {
      std::vector<float> p, c;
      detail::classifier_inputs(cls, ctx.info(), motions[n].pose, motions[n].control, run.context.control_dim,
                                "label sample " + std::to_string(k) + "." + std::to_string(n), &p, &c);
      set.poses.push_back(std::move(p));
      set.controls.push_back(std::move(c));
      set.content.push_back(ci);
      set.style.push_back(si);
    }
  }
  ctx.report("label generation", combinations, combinations);
  return set;
}

LabelledSet LabelGenerationProtocol::real_clips(const EvalContext& ctx, const nn::LoadedRun& cls) const {
  const data::DatasetInfo& info = ctx.info();
  LabelledSet set;
  for (const data::ClipRecord& rec : ctx.dataset().clips(ctx.options().split)) {
    if ((rec.mirrored || rec.reversed) && !ctx.options().include_augmented) continue;
    std::vector<float> p, c;
    detail::classifier_inputs(cls, info, rec.pose, rec.control, ctx.run().context.control_dim, rec.source, &p, &c);
    set.poses.push_back(std::move(p));
    set.controls.push_back(std::move(c));
    set.content.push_back(nn::translate_label(rec.content, info.content_labels, cls.dataset.content_labels));
    set.style.push_back(nn::translate_label(rec.style, info.style_labels, cls.dataset.style_labels));
  }
  if (set.poses.empty()) throw Error("evaluate: label generation found no real clip in the " + ctx.options().split + " split");
  return set;
}

void LabelGenerationProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const nn::LoadedRun cls = detail::load_classifier(ctx.options());
  const LabelledSet model = sample_every_combination(ctx, cls), real = real_clips(ctx, cls);
  const nn::ClassifierOutputs mo = nn::classify_windows(cls, model.poses, model.controls);
  const nn::ClassifierOutputs ro = nn::classify_windows(cls, real.poses, real.controls);
  auto row = [&](const std::string& key, const std::string& label, double m, double r) {
    result.rows.push_back({"label_generation." + key, "by label: " + label, m, r});
  };
  row("samples", "motions scored (samples: every label combination)", mo.num_windows, ro.num_windows);
  const std::vector<int> all(model.content.size(), -1), all_real(real.content.size(), -1);
  row("is_content", "Inception score (content)",
      inception_score(rows_with(mo.content_probabilities, mo.num_content, all, -1)),
      inception_score(rows_with(ro.content_probabilities, ro.num_content, all_real, -1)));
  if (mo.num_style > 0)
    row("is_style", "Inception score (style)", inception_score(rows_with(mo.style_probabilities, mo.num_style, all, -1)),
        inception_score(rows_with(ro.style_probabilities, ro.num_style, all_real, -1)));
  const Eigen::MatrixXd fm = rows_with(mo.features, mo.num_features, all, -1);
  const Eigen::MatrixXd fr = rows_with(ro.features, ro.num_features, all_real, -1);
  row("fid", "FID (all samples vs the real clips; real: split-half floor)", fid_or_nan(fm, fr), detail::split_half_fid(fr));
  row("content_acc", "requested content recognised (%)",
      recognised_percent(mo.content_probabilities, mo.num_content, model.content),
      recognised_percent(ro.content_probabilities, ro.num_content, real.content));
  if (mo.num_style > 0)
    row("style_acc", "requested style recognised (%)",
        recognised_percent(mo.style_probabilities, mo.num_style, model.style),
        recognised_percent(ro.style_probabilities, ro.num_style, real.style));
  // FID per requested label against the real clips of that label.
  auto per_label = [&](const std::string& kind, const std::vector<std::string>& names, const std::vector<int>& m_labels,
                       const std::vector<int>& r_labels) {
    for (int id = 0; id < static_cast<int>(names.size()); ++id) {
      const Eigen::MatrixXd a = rows_with(mo.features, mo.num_features, m_labels, id);
      const Eigen::MatrixXd b = rows_with(ro.features, ro.num_features, r_labels, id);
      if (a.rows() == 0 || b.rows() == 0) continue;
      row("fid." + kind + "." + names[id], "FID of " + kind + " " + names[id] + " (real: split-half floor)",
          fid_or_nan(a, b), detail::split_half_fid(b));
    }
  };
  per_label("content", cls.dataset.content_labels, model.content, real.content);
  per_label("style", cls.dataset.style_labels, model.style, real.style);
}

}  // namespace

std::unique_ptr<Protocol> make_label_generation_protocol() { return std::make_unique<LabelGenerationProtocol>(); }

}  // namespace mosyn::eval
