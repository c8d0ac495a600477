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
#include "nn/sample_job.h"

namespace mosyn::eval {

namespace {

using detail::ClassifierInputs;
using detail::to_matrix;

// Rows of a [N, cols] float matrix whose label equals `label`, as Eigen.
Eigen::MatrixXd rows_with(const std::vector<float>& values, int cols, const std::vector<int>& labels, int label) {
  std::vector<int> keep;
  for (size_t i = 0; i < labels.size(); ++i)
    if (labels[i] == label) keep.push_back(static_cast<int>(i));
  Eigen::MatrixXd m(static_cast<Eigen::Index>(keep.size()), cols);
  for (size_t r = 0; r < keep.size(); ++r)
    for (int c = 0; c < cols; ++c) m(static_cast<Eigen::Index>(r), c) = values[static_cast<size_t>(keep[r]) * cols + c];
  return m;
}

class LabelGenerationProtocol : public Protocol {
 public:
  std::string name() const override { return "label_generation"; }
  bool enabled(const EvalOptions& o) const override { return o.label_samples > 0 && !o.classifier_dir.empty(); }
  bool applies_to(const nn::ModelTraits& t) const override { return t.labels; }
  void run(EvalContext& ctx, EvalResult& result) const override;

 private:
  void sample_every_combination(EvalContext& ctx, const nn::LoadedRun& cls, ClassifierInputs* set) const;
  void real_clips(const EvalContext& ctx, const nn::LoadedRun& cls, ClassifierInputs* set) const;
};

void LabelGenerationProtocol::sample_every_combination(EvalContext& ctx, const nn::LoadedRun& cls,
                                                       ClassifierInputs* set) const {
  const EvalOptions& o = ctx.options();
  const nn::LoadedRun& run = ctx.run();
  const double seconds = o.label_seconds > 0 ? o.label_seconds : ctx.info().window_frames / run.dataset.fps;
  const std::vector<float> control = detail::long_horizon_control(run, seconds);
  const auto& contents = run.dataset.content_labels;
  const auto& styles = run.dataset.style_labels;
  const int num_styles = std::max<int>(1, static_cast<int>(styles.size()));
  const int combinations = std::max<int>(1, static_cast<int>(contents.size())) * num_styles;
  for (int k = 0; k < combinations; ++k) {
    ctx.report("label generation", k, combinations);
    nn::SampleExtras extras;
    extras.content = contents.empty() ? -1 : k / num_styles;
    extras.style = styles.empty() ? -1 : k % num_styles;
    const auto motions = nn::sample_motions(run, control, o.label_samples, o.seed + 9000001 + 1000 * k, o.temperature,
                                            extras);
    const int ci = nn::translate_label(extras.content, contents, cls.dataset.content_labels);
    const int si = nn::translate_label(extras.style, styles, cls.dataset.style_labels);
    for (size_t n = 0; n < motions.size(); ++n)
      set->add_in_windows(motions[n].pose, motions[n].control, "label sample " + std::to_string(k) + "." + std::to_string(n), ci,
               si);
  }
  ctx.report("label generation", combinations, combinations);
}

void LabelGenerationProtocol::real_clips(const EvalContext& ctx, const nn::LoadedRun& cls, ClassifierInputs* set) const {
  const data::DatasetInfo& info = ctx.info();
  for (const data::ClipRecord& rec : ctx.dataset().clips(ctx.options().split)) {
    if (rec.augmented() && !ctx.options().include_augmented) continue;
    set->add_in_windows(rec.pose, rec.control, rec.source,
             nn::translate_label(rec.content, info.content_labels, cls.dataset.content_labels),
             nn::translate_label(rec.style, info.style_labels, cls.dataset.style_labels));
  }
  if (set->poses.empty())
    throw Error("evaluate: label generation found no real clip in the " + ctx.options().split + " split");
}

void LabelGenerationProtocol::run(EvalContext& ctx, EvalResult& result) const {
  const nn::LoadedRun cls = detail::load_classifier(ctx.options());
  ClassifierInputs model(cls, ctx.info()), real(cls, ctx.info());
  sample_every_combination(ctx, cls, &model);
  real_clips(ctx, cls, &real);
  const nn::ClassifierOutputs mo = model.classify(), ro = real.classify();
  auto row = [&](const std::string& key, const std::string& label, double m, double r) {
    result.rows.push_back({"label_generation." + key, "by label: " + label, m, r});
  };
  row("samples", "windows scored (samples: every label combination)", mo.num_windows, ro.num_windows);
  row("is_content", "Inception score (content)",
      inception_score(to_matrix(mo.content_probabilities, mo.num_windows, mo.num_content)),
      inception_score(to_matrix(ro.content_probabilities, ro.num_windows, ro.num_content)));
  if (mo.num_style > 0)
    row("is_style", "Inception score (style)",
        inception_score(to_matrix(mo.style_probabilities, mo.num_windows, mo.num_style)),
        inception_score(to_matrix(ro.style_probabilities, ro.num_windows, ro.num_style)));
  const Eigen::MatrixXd fm = to_matrix(mo.features, mo.num_windows, mo.num_features);
  const Eigen::MatrixXd fr = to_matrix(ro.features, ro.num_windows, ro.num_features);
  row("fid", "FID (all samples vs the real clips; real: split-half floor)", detail::fid_or_nan(fm, fr),
      detail::split_half_fid(fr));
  row("content_acc", "requested content recognised (%)",
      detail::recognised_percent(mo.content_probabilities, mo.num_content, model.content),
      detail::recognised_percent(ro.content_probabilities, ro.num_content, real.content));
  if (mo.num_style > 0)
    row("style_acc", "requested style recognised (%)",
        detail::recognised_percent(mo.style_probabilities, mo.num_style, model.style),
        detail::recognised_percent(ro.style_probabilities, ro.num_style, real.style));
  // FID per requested label against the real clips of that label.
  auto per_label = [&](const std::string& kind, const std::vector<std::string>& names, const std::vector<int>& m_labels,
                       const std::vector<int>& r_labels) {
    for (int id = 0; id < static_cast<int>(names.size()); ++id) {
      const Eigen::MatrixXd a = rows_with(mo.features, mo.num_features, m_labels, id);
      const Eigen::MatrixXd b = rows_with(ro.features, ro.num_features, r_labels, id);
      if (a.rows() == 0 || b.rows() == 0) continue;
      row("fid." + kind + "." + names[id], "FID of " + kind + " " + names[id] + " (real: split-half floor)",
          detail::fid_or_nan(a, b), detail::split_half_fid(b));
    }
  };
  per_label("content", cls.dataset.content_labels, model.content, real.content);
  per_label("style", cls.dataset.style_labels, model.style, real.style);
}

}  // namespace

std::unique_ptr<Protocol> make_label_generation_protocol() { return std::make_unique<LabelGenerationProtocol>(); }

}  // namespace mosyn::eval
