// The family-agnostic interface every probabilistic motion model in mosyn implements
// (MoGlow, recurrent VAE, hierarchical VRNN, Dynamic Future Net, MOJO). Families register
// themselves (nn/registry.h); see src/nn/README.md for how to add one.
//
// Conventions shared by all families:
// - Tensors are batch-first: pose [B, T, D], control [B, T, C] (C = 3: dx, dz metres and
//   dtheta radians, the delta from frame t-1 to t, see data/representation.h).
// - Inside the model every pose and control value is STANDARDISED with the dataset statistics:
//   x_std = (x_raw - mean) / std per dimension. Converting raw <-> standardised is the caller's
//   job (nn/training and nn/sampling do it with the run's stats.json).
// - Labels content [B] and style [B] are int64 indices into the dataset's vocabularies, -1 = none.
// - Likelihoods are natural-log based (nats).
#pragma once

#include <torch/nn/module.h>
#include <torch/types.h>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "nn/context.h"
#include "nn/registry.h"
#include "nn/trainable.h"
#include "nn/traits.h"

namespace mosyn::nn {

// A request for random motion. All tensors standardised; poses and controls batch-first.
struct SampleRequest {
  torch::Tensor control;         // [B, T, C]: control of the T frames to generate (families
                                 // without control use only its shape: B and T)
  torch::Tensor prefix_pose;     // optional [B, P, D]: motion preceding the generated frames
  torch::Tensor prefix_control;  // optional [B, P, C]: its control (zeros = mean when undefined)
  torch::Tensor content;         // optional [B] int64 labels, -1 = none
  torch::Tensor style;           // optional [B] int64 labels, -1 = none
  double temperature = 1.0;      // standard deviation multiplier of the latent noise
  std::uint64_t seed = 0;        // seeds a private generator: same seed + inputs = same output
  // Optional per-character seeds (B entries). Families that draw each character's noise from its
  // own generator (ModelTraits::independent_rows) seed row k with seeds[k], else with
  // row_seed(seed, k); other families use `seed` alone.
  std::vector<std::uint64_t> seeds;
  int batch = 0;                 // for begin_stream only: batch size B when no tensor gives it
};

// What sampling returns: the poses and the root motion they move along, standardised.
struct SampleOutput {
  torch::Tensor pose;     // [B, T, D]
  torch::Tensor control;  // [B, T, C]: the request's control for families that take it, the
                          // generated root motion for families that generate it (ModelTraits)
};

// One frame of a stream, standardised.
struct StreamFrame {
  torch::Tensor pose;     // [B, D]
  torch::Tensor control;  // [B, C]: the given control, or the generated root motion
};

// Wall-clock time of a named stage of the last sample() call, for families that report one (MOJO:
// its recursive projection).
struct SampleStageTiming {
  std::string stage;     // e.g. "projection"
  double seconds = 0.0;  // wall-clock in the stage
  long steps = 0;        // times the stage ran (MOJO: predicted frames, each for the whole batch)
  long rows = 0;         // row-steps it processed (MOJO: sample-frames fitted)
};

// Opaque per-family state of a streaming (frame-by-frame) generation.
class StreamState {
 public:
  virtual ~StreamState() = default;
};

// Abstract motion model: a trainable model (nn/trainable.h) that generates motion. Its traits()
// say which inputs it takes and which it generates; callers follow them, never the family name.
class MotionModel : public TrainableModel {
 public:
  explicit MotionModel(std::string name) : TrainableModel(std::move(name)) {}
  ~MotionModel() override = default;

  // Which inputs the family takes, ignores or generates (nn/traits.h). May depend on the config
  // (e.g. labels only when trained with labels).
  virtual ModelTraits traits() const = 0;

  // Random motion: poses (and root motion) of request.control's B x T frames. Families that take
  // control return request.control as SampleOutput::control. Deterministic given the request (seed
  // included); no gradient is recorded.
  virtual SampleOutput sample(const SampleRequest& request) = 0;

  // Streaming, for families whose traits().streaming is true. Starts a stream from the request's
  // prefix, labels, temperature and seed (request.control is ignored; the batch size comes from
  // prefix_pose, content, style or request.batch).
  virtual std::unique_ptr<StreamState> begin_stream(const SampleRequest& request);
  // Advances a stream by one frame: control [B, C] standardised of the new frame t (the delta
  // t-1 -> t; undefined for families that generate their root motion) gives frame t.
  virtual StreamFrame step_stream(StreamState& state, const torch::Tensor& control);
  // The same with the control predicted for the frames after t (ModelTraits::control_ahead_frames
  // of them): control_ahead [B, K, C] standardised, made from the input up to t only (a real-time
  // controller's simulated root, data/root_controller.h), so the stream stays causal. Families that
  // read no path ahead ignore it (the default); undefined = the control of frame t held.
  virtual StreamFrame step_stream_ahead(StreamState& state, const torch::Tensor& control,
                                         const torch::Tensor& control_ahead);
  // Replaces row dst_row of stream dst by row src_row of stream src (both from begin_stream of
  // this model, possibly of different batch sizes): the character's whole state (history,
  // recurrent state, labels, noise generator) moves, so it continues exactly as it would have in
  // src. Lets a runtime add a character to a running batch. Families without per-row state throw
  // mosyn::Error (the default).
  virtual void copy_stream_row(StreamState& dst, int64_t dst_row, const StreamState& src, int64_t src_row);
  // Reseeds row `row`'s noise generator (as begin_stream seeds it), leaving the rest of its state:
  // a character started from another's state (copy_stream_row) then draws its own noise. Families
  // without per-row generators throw mosyn::Error (the default).
  virtual void reseed_stream_row(StreamState& state, int64_t row, std::uint64_t seed);

  // Timings of the stages of the last sample() call the family measures; none by default.
  virtual std::vector<SampleStageTiming> last_sample_timings() const { return {}; }
};

// Seed of row `row` of a batch drawn from one seed: the seed itself for row 0 (so a batch of one
// equals a character started alone with that seed), a splitmix64 mix of both for the others.
std::uint64_t row_seed(std::uint64_t seed, int64_t row);

// Builds a motion model of a registered family (nn/registry.h) from a (possibly partial) config;
// missing keys take the family's defaults; a "preset" key selects a named set of defaults first.
// Parameters are initialised from the default torch generator (call torch::manual_seed first for
// reproducibility). Throws mosyn::Error for an unknown family, a family that does not generate
// motion (a classifier), an unknown key or an invalid value.
std::shared_ptr<MotionModel> create_model(const std::string& family, const nlohmann::json& config,
                                          const ModelContext& context);

// Sets the number of intra-op CPU threads LibTorch uses; threads <= 0 means all cores.
// Returns the number set.
int set_num_threads(int threads);

// "cpu" or "cuda"/"cuda:N" to a torch::Device; throws mosyn::Error when CUDA is asked for but
// not available.
torch::Device parse_device(const std::string& device);

}  // namespace mosyn::nn
