// `mosyn eval` of a classifier run (FamilyKind::kClassifier): how well it recognises the held-out
// clips that it judges models against. Its recognition, Inception Score and FID floor on them are
// the "real" rows of the recognition protocol (recognition.cpp); here they come per label too, so
// a model card can say which contents and styles a classifier confuses.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "eval/protocols/protocols.h"
#include "metrics/metrics.h"
#include "nn/sample_job.h"

namespace mosyn::eval {

namespace {

using detail::to_matrix;

// Rows "<prefix>.<label>": the percentage of the windows of each label that are recognised as it,
// for the labels of `vocabulary` that the windows hold.
void per_label_rows(const std::string& prefix, const std::string& what, const std::vector<std::string>& vocabulary,
                    const std::vector<float>& probabilities, int k, const std::vector<int>& labels, EvalResult* result) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  for (int l = 0; l < static_cast<int>(vocabulary.size()); ++l) {
    int windows = 0, right = 0;
    for (size_t w = 0; w < labels.size(); ++w) {
      if (labels[w] != l) continue;
      ++windows;
      right += detail::arg_max(probabilities, k, static_cast<int>(w)) == l;
    }
    if (windows > 0)
      result->rows.push_back({prefix + "." + vocabulary[l], what + " " + vocabulary[l] + " recognised (%)",
                              100.0 * right / windows, kNaN});
  }
}

}  // namespace

EvalResult evaluate_classifier(const nn::LoadedRun& cls, const data::Dataset& dataset, const EvalOptions& o,
                               const EvalProgressCallback& progress) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (o.max_clips < 0) throw Error("evaluate: max_clips must not be negative");
  const data::DatasetInfo& info = dataset.info();
  const auto& all = dataset.clips(o.split);
  std::vector<int> candidates;  // as EvalContext chooses a motion model's held-out clips
  for (int i = 0; i < static_cast<int>(all.size()); ++i)
    if (all[i].num_frames >= 2 && (o.include_augmented || !all[i].augmented())) candidates.push_back(i);
  if (candidates.empty()) throw Error("evaluate: the '" + o.split + "' split has no clip to evaluate");
  const size_t n_clips = o.max_clips > 0 ? std::min<size_t>(o.max_clips, candidates.size()) : candidates.size();

  EvalResult result;
  result.run_dir = cls.run_dir;
  result.family = cls.family;
  result.split = o.split;
  result.seed = o.seed;
  detail::ClassifierInputs real(cls, info);
  for (size_t i = 0; i < n_clips; ++i) {
    const int index = candidates[i * candidates.size() / n_clips];
    const data::ClipRecord& rec = all[index];
    result.clip_indices.push_back(index);
    result.clips.push_back(rec.source);
    real.add_in_windows(rec.pose, rec.control, rec.source,
                        nn::translate_label(rec.content, info.content_labels, cls.dataset.content_labels),
                        nn::translate_label(rec.style, info.style_labels, cls.dataset.style_labels));
  }
  if (progress) progress(EvalProgress{"classifier", 0, 1});
  const nn::ClassifierOutputs out = real.classify();
  auto& rows = result.rows;
  rows.push_back({"classifier.windows", "windows scored", static_cast<double>(out.num_windows), kNaN});
  rows.push_back({"classifier.content_acc", "content recognised (%)",
                  detail::recognised_percent(out.content_probabilities, out.num_content, real.content), kNaN});
  if (out.num_style > 0)
    rows.push_back({"classifier.style_acc", "style recognised (%)",
                    detail::recognised_percent(out.style_probabilities, out.num_style, real.style), kNaN});
  rows.push_back({"classifier.is", "Inception score (content) of the held-out clips",
                  inception_score(to_matrix(out.content_probabilities, out.num_windows, out.num_content)), kNaN});
  if (out.num_style > 0)
    rows.push_back({"classifier.style_is", "Inception score (style) of the held-out clips",
                    inception_score(to_matrix(out.style_probabilities, out.num_windows, out.num_style)), kNaN});
  rows.push_back({"classifier.fid_floor", "FID of the held-out clips' two halves (features; a model's floor)",
                  detail::split_half_fid(to_matrix(out.features, out.num_windows, out.num_features)), kNaN});
  per_label_rows("classifier.content_acc", "content", cls.dataset.content_labels, out.content_probabilities,
                 out.num_content, real.content, &result);
  if (out.num_style > 0)
    per_label_rows("classifier.style_acc", "style", cls.dataset.style_labels, out.style_probabilities, out.num_style,
                   real.style, &result);
  result.protocols.push_back("classification");
  if (progress) progress(EvalProgress{"classifier", 1, 1});
  return result;
}

}  // namespace mosyn::eval
