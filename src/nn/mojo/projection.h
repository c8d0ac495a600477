// MOJO's recursive projection (Zhang et al. 2021, Sec. 3.4) on mosyn's skeletons: after every
// predicted frame, the skeleton's joint rotations and root are fitted to the predicted markers
// (Ceres Levenberg-Marquardt, nn/mojo/ceres_fit.h; warm-started from the previous frame's fit, a small pose-change prior)
// and the fitted body's own markers replace the prediction before it is fed back. Rows of a
// batch are fitted in parallel threads. No LibTorch in the interface's numerics: frames come in
// and go out as float rows of the model's (standardised) feature vector.
#pragma once

#include <memory>
#include <vector>

#include "core/markers.h"
#include "core/skeleton.h"

namespace mosyn::nn::mojo {

struct ProjectionOptions {
  int iterations = 10;        // LM iterations per predicted frame (warm start: a few suffice)
  int first_iterations = 200; // for the first frame, from the canonical pose
  double pose_prior = 1e-4;   // the fit's pose-change prior (metres^2 per radian^2)
  int threads = 0;            // rows fitted in parallel; 0 = hardware concurrency
};

// Timing of the fits so far (wall-clock of project() calls and their fitted frames).
struct ProjectionTiming {
  long frames = 0;        // row-frames fitted
  long calls = 0;         // project() calls (one per predicted frame of a batch)
  double seconds = 0.0;   // wall-clock inside project()
};

// Projects rows of standardised feature vectors (marker features first: 41 x 3 metres, in the
// marker pose form's layout; further features untouched) onto the skeleton's valid bodies.
class MarkerProjector {
 public:
  // mean, std: the features' standardisation of the first 123 entries (metres).
  MarkerProjector(const Skeleton& skeleton, std::vector<double> mean, std::vector<double> std, int rows,
                  const ProjectionOptions& options);
  // frames [rows x stride] row-major standardised features; each row's first 123 entries are
  // replaced by the markers of the body fitted to them. The first call starts every row from
  // the canonical pose placed at its waist markers; later calls warm-start from the last fit.
  void project(float* frames, int stride);
  const ProjectionTiming& timing() const { return timing_; }
  void reset_timing() { timing_ = {}; }
  // The last fitted body of each row (one-frame motions).
  const std::vector<Motion>& bodies() const { return bodies_; }
  // Root mean squared marker distance (metres) of the last call's fits, averaged over rows.
  double last_rms_m() const { return last_rms_m_; }

 private:
  Skeleton skeleton_;
  MarkerSet markers_;
  std::vector<double> mean_, std_;
  ProjectionOptions options_;
  std::vector<Motion> bodies_;
  std::vector<bool> started_;
  std::vector<double> rms_;
  ProjectionTiming timing_;
  double last_rms_m_ = 0.0;
};

}  // namespace mosyn::nn::mojo
