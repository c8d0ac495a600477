#include "nn/mojo/projection.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

#include "core/error.h"
#include "core/kinematics.h"
#include "nn/mojo/ceres_fit.h"

namespace mosyn::nn::mojo {

MarkerProjector::MarkerProjector(const Skeleton& skeleton, std::vector<double> mean, std::vector<double> std, int rows,
                                 const ProjectionOptions& options)
    : skeleton_(skeleton), markers_(cmu41_markers(skeleton)), mean_(std::move(mean)), std_(std::move(std)),
      options_(options) {
  const size_t dims = 3 * static_cast<size_t>(markers_.num_markers());
  if (mean_.size() < dims || std_.size() < dims)
    throw Error("mojo projection: the statistics have fewer than " + std::to_string(dims) + " marker features");
  if (rows < 0) throw Error("mojo projection: negative row count");
  bodies_.assign(rows, Motion::rest(skeleton_, 1, 30.0));
  started_.assign(rows, false);
  rms_.assign(rows, 0.0);
}

void MarkerProjector::project(float* frames, int stride) {
  const auto start = std::chrono::steady_clock::now();
  const int rows = static_cast<int>(bodies_.size());
  const int m = markers_.num_markers();
  const double units_per_m = 1.0 / skeleton_.meters_per_unit;
  auto work = [&](int r) {
    float* row = frames + static_cast<size_t>(r) * stride;
    std::vector<Eigen::Vector3d> targets(m);
    for (int i = 0; i < m; ++i)
      for (int k = 0; k < 3; ++k) {
        const int d = 3 * i + k;
        targets[i][k] = (row[d] * std_[d] + mean_[d]) * units_per_m;
      }
    CeresFitOptions fit;
    fit.pose_prior = options_.pose_prior;
    fit.max_iterations = options_.iterations;
    if (!started_[r]) {
      initialise_from_markers(skeleton_, markers_, targets, &bodies_[r], 0);
      fit.max_iterations = options_.first_iterations;
      fit.pose_prior = 0.0;  // nothing to stay near yet
      started_[r] = true;
    }
    const MarkerFitResult result = fit_markers_ceres(skeleton_, markers_, targets, &bodies_[r], 0, fit);
    rms_[r] = result.rms_error * skeleton_.meters_per_unit;
    const auto& fitted = result.fitted;  // the fit's own forward kinematics, not repeated here
    for (int i = 0; i < m; ++i)
      for (int k = 0; k < 3; ++k) {
        const int d = 3 * i + k;
        row[d] = static_cast<float>((fitted[i][k] * skeleton_.meters_per_unit - mean_[d]) / std_[d]);
      }
  };
  int threads = options_.threads > 0 ? options_.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::max(1, std::min(threads, rows));
  if (threads == 1) {
    for (int r = 0; r < rows; ++r) work(r);
  } else {
    std::atomic<int> next{0};
    std::vector<std::thread> pool;
    std::exception_ptr failure;
    std::atomic<bool> failed{false};
    for (int i = 0; i < threads; ++i)
      pool.emplace_back([&] {
        for (int r = next++; r < rows; r = next++) {
          try {
            work(r);
          } catch (...) {
            if (!failed.exchange(true)) failure = std::current_exception();
          }
        }
      });
    for (auto& th : pool) th.join();
    if (failure) std::rethrow_exception(failure);
  }
  double sum = 0.0;
  for (double v : rms_) sum += v;
  last_rms_m_ = rows > 0 ? sum / rows : 0.0;
  timing_.frames += rows;
  timing_.calls += 1;
  timing_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace mosyn::nn::mojo
