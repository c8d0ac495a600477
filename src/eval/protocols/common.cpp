#include <algorithm>
#include <cmath>

#include "eval/protocols/protocols.h"

namespace mosyn::eval::detail {

double mean_finite(const std::vector<double>& values) {
  double sum = 0;
  int n = 0;
  for (double v : values)
    if (std::isfinite(v)) {
      sum += v;
      ++n;
    }
  return n > 0 ? sum / n : kNaN;
}

std::vector<float> rows_of(const std::vector<float>& a, int from, int to, int dim) {
  return std::vector<float>(a.begin() + static_cast<size_t>(from) * dim, a.begin() + static_cast<size_t>(to) * dim);
}

Eigen::MatrixXd to_matrix(const std::vector<float>& v, int rows, int cols) {
  Eigen::MatrixXd m(rows, cols);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) m(r, c) = v[static_cast<size_t>(r) * cols + c];
  return m;
}

Eigen::MatrixXd root_relative(const Eigen::MatrixXd& sequence) {
  Eigen::MatrixXd out = sequence;
  for (Eigen::Index j = 0; j + 2 < out.cols(); j += 3) out.middleCols(j, 3) -= sequence.leftCols(3);
  return out;
}

nn::SampleExtras walk_extras(const nn::LoadedRun& run, int warmup_frames) {
  nn::SampleExtras extras;
  extras.warmup_frames = warmup_frames;
  const auto& labels = run.dataset.content_labels;
  const auto walk = std::find(labels.begin(), labels.end(), "walk");
  if (run.traits.labels && walk != labels.end()) extras.content = static_cast<int>(walk - labels.begin());
  return extras;
}

}  // namespace mosyn::eval::detail
