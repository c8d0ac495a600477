// Recognisability of the samples by a trained classifier run (Ghorbani et al. 2020, section 5.2):
// content / style accuracy, Inception score, FID.
#include <algorithm>

#include "core/error.h"
#include "nn/sample_job.h"
#include "eval/protocols/protocols.h"

namespace mosyn::eval {

namespace {

using detail::recognised_percent;
using detail::to_matrix;
using nn::translate_label;

// The samples along each held-out clip's control (model) and the real clips (real), labelled with
// the clip's own labels.
void gather(EvalContext& ctx, const nn::LoadedRun& cls, detail::ClassifierInputs* model,
            detail::ClassifierInputs* real) {
  const data::DatasetInfo& info = ctx.info();
  const auto& motions = ctx.sampled_motions();
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    const data::ClipRecord& rec = ctx.clip(i);
    const int ci = translate_label(rec.content, info.content_labels, cls.dataset.content_labels);
    const int si = translate_label(rec.style, info.style_labels, cls.dataset.style_labels);
    for (int k = 0; k < ctx.num_samples(); ++k)
      model->add_in_windows(motions[i][k].pose, motions[i][k].control, rec.source + " sample " + std::to_string(k), ci, si);
    real->add_in_windows(rec.pose, rec.control, rec.source, ci, si);
  }
}

class RecognitionProtocol : public Protocol {
 public:
  std::string name() const override { return "recognition"; }
  bool enabled(const EvalOptions& o) const override { return !o.classifier_dir.empty(); }
  bool applies_to(const nn::ModelTraits&) const override { return true; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    ctx.report("classifier", 0, 1);
    const nn::LoadedRun cls = detail::load_classifier(ctx.options());
    detail::ClassifierInputs model(cls, ctx.info()), real(cls, ctx.info());
    gather(ctx, cls, &model, &real);
    const nn::ClassifierOutputs mo = model.classify(), ro = real.classify();
    result.rows.push_back({"classifier.content_acc", "classifier content accuracy (%)",
                           recognised_percent(mo.content_probabilities, mo.num_content, model.content),
                           recognised_percent(ro.content_probabilities, ro.num_content, real.content)});
    if (mo.num_style > 0)
      result.rows.push_back({"classifier.style_acc", "classifier style accuracy (%)",
                             recognised_percent(mo.style_probabilities, mo.num_style, model.style),
                             recognised_percent(ro.style_probabilities, ro.num_style, real.style)});
    result.rows.push_back({"classifier.is", "Inception score (content)",
                           inception_score(to_matrix(mo.content_probabilities, mo.num_windows, mo.num_content)),
                           inception_score(to_matrix(ro.content_probabilities, ro.num_windows, ro.num_content))});
    const Eigen::MatrixXd fm = to_matrix(mo.features, mo.num_windows, mo.num_features);
    const Eigen::MatrixXd fr = to_matrix(ro.features, ro.num_windows, ro.num_features);
    result.rows.push_back({"classifier.fid", "FID (classifier features, vs real data)", detail::fid_or_nan(fm, fr),
                           detail::split_half_fid(fr)});
    ctx.report("classifier", 1, 1);
  }
};

}  // namespace

std::unique_ptr<Protocol> make_recognition_protocol() { return std::make_unique<RecognitionProtocol>(); }

}  // namespace mosyn::eval
