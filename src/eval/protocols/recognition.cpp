// Recognisability of the samples by a trained classifier run (Ghorbani et al. 2020, section 5.2):
// content / style accuracy, Inception score, FID.
#include <algorithm>

#include "core/error.h"
#include "nn/sample_job.h"
#include "eval/protocols/protocols.h"
#include "nn/classifier/classify.h"

namespace mosyn::eval {

namespace {

using detail::kNaN;
using nn::translate_label;
using detail::to_matrix;

// Classifier inputs (raw poses and controls) and label ids, of the samples or of the real clips.
struct Inputs {
  std::vector<std::vector<float>> poses, controls;
  std::vector<int> content, style;  // classifier label ids, -1 = none
};

// The samples (model) and the real clips (real) as the classifier's data. Another feature form
// (e.g. a joint-position model scored by a joint-rotation classifier): every motion is decoded to
// a clip and encoded as the classifier's data, so one classifier scores every family. Same form:
// the features as they are.
void gather(EvalContext& ctx, const nn::LoadedRun& cls, Inputs* model, Inputs* real) {
  const data::DatasetInfo& info = ctx.info();
  const int c = ctx.run().context.control_dim;
  auto add = [&](Inputs* to, const std::vector<float>& pose, const std::vector<float>& control, const std::string& name,
                 int ci, int si) {
    std::vector<float> p, k;
    detail::classifier_inputs(cls, info, pose, control, c, name, &p, &k);
    to->poses.push_back(std::move(p));
    to->controls.push_back(std::move(k));
    to->content.push_back(ci);
    to->style.push_back(si);
  };
  const auto& motions = ctx.sampled_motions();
  for (size_t i = 0; i < ctx.num_clips(); ++i) {
    const data::ClipRecord& rec = ctx.clip(i);
    const int ci = translate_label(rec.content, info.content_labels, cls.dataset.content_labels);
    const int si = translate_label(rec.style, info.style_labels, cls.dataset.style_labels);
    for (int k = 0; k < ctx.num_samples(); ++k)
      add(model, motions[i][k].pose, motions[i][k].control, rec.source + " sample " + std::to_string(k), ci, si);
    add(real, rec.pose, rec.control, rec.source, ci, si);
  }
}

// Percentage of rows whose arg-max is the label (rows with label -1 skipped); NaN when none.
double accuracy(const std::vector<float>& probs, int k, const std::vector<int>& labels) {
  int right = 0, total = 0;
  for (size_t i = 0; i < labels.size(); ++i) {
    if (labels[i] < 0) continue;
    const float* row = probs.data() + i * k;
    right += static_cast<int>(std::max_element(row, row + k) - row) == labels[i];
    ++total;
  }
  return total > 0 ? 100.0 * right / total : kNaN;
}

class RecognitionProtocol : public Protocol {
 public:
  std::string name() const override { return "recognition"; }
  bool enabled(const EvalOptions& o) const override { return !o.classifier_dir.empty(); }
  bool applies_to(const nn::ModelTraits&) const override { return true; }
  void run(EvalContext& ctx, EvalResult& result) const override {
    ctx.report("classifier", 0, 1);
    const nn::LoadedRun cls = detail::load_classifier(ctx.options());
    Inputs model, real;
    gather(ctx, cls, &model, &real);
    const nn::ClassifierOutputs mo = nn::classify_windows(cls, model.poses, model.controls);
    const nn::ClassifierOutputs ro = nn::classify_windows(cls, real.poses, real.controls);
    result.rows.push_back({"classifier.content_acc", "classifier content accuracy (%)",
                           accuracy(mo.content_probabilities, mo.num_content, model.content),
                           accuracy(ro.content_probabilities, ro.num_content, real.content)});
    if (mo.num_style > 0)
      result.rows.push_back({"classifier.style_acc", "classifier style accuracy (%)",
                             accuracy(mo.style_probabilities, mo.num_style, model.style),
                             accuracy(ro.style_probabilities, ro.num_style, real.style)});
    result.rows.push_back({"classifier.is", "Inception score (content)",
                           inception_score(to_matrix(mo.content_probabilities, mo.num_windows, mo.num_content)),
                           inception_score(to_matrix(ro.content_probabilities, ro.num_windows, ro.num_content))});
    const Eigen::MatrixXd fm = to_matrix(mo.features, mo.num_windows, mo.num_features);
    const Eigen::MatrixXd fr = to_matrix(ro.features, ro.num_windows, ro.num_features);
    const double fid_model = fm.rows() >= 2 && fr.rows() >= 2 ? frechet_inception_distance(fm, fr) : kNaN;
    result.rows.push_back({"classifier.fid", "FID (classifier features, vs real data)", fid_model, detail::split_half_fid(fr)});
    ctx.report("classifier", 1, 1);
  }
};

}  // namespace

std::unique_ptr<Protocol> make_recognition_protocol() { return std::make_unique<RecognitionProtocol>(); }

}  // namespace mosyn::eval
