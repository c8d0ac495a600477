// The family-agnostic interface every probabilistic motion model in mosyn implements
// (MoGlow, recurrent VAE, hierarchical VRNN, Dynamic Future Net, MOJO), and the registry that
// builds one from a family name and a JSON config.
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

namespace mosyn::nn {

// One training or validation mini-batch, standardised.
struct Batch {
  torch::Tensor pose;     // [B, T, D] float, standardised
  torch::Tensor control;  // [B, T, C] float, standardised
  torch::Tensor content;  // [B] int64, -1 = none (may be undefined: all none)
  torch::Tensor style;    // [B] int64, -1 = none (may be undefined: all none)
};

// Named scalar tensors returned by MotionModel::loss. terms["loss"] is the total that the
// optimiser minimises (0-dim, differentiable); the others are detached metrics for logging,
// e.g. "nll_frame" (nats per predicted frame) and "nll_dim" (nats per frame and dimension).
struct LossTerms {
  std::map<std::string, torch::Tensor> terms;
  const torch::Tensor& loss() const { return terms.at("loss"); }
};

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
  int batch = 0;                 // for begin_stream only: batch size B when no tensor gives it
};

// Opaque per-family state of a streaming (frame-by-frame) generation.
class StreamState {
 public:
  virtual ~StreamState() = default;
};

// Abstract motion model. Implementations are torch::nn::Modules whose parameters and buffers
// are everything a checkpoint must hold besides config().
class MotionModel : public torch::nn::Module {
 public:
  explicit MotionModel(std::string name) : torch::nn::Module(std::move(name)) {}
  ~MotionModel() override = default;

  // Family name as accepted by create_model, e.g. "moglow".
  virtual std::string family() const = 0;

  // The fully resolved model config (defaults filled in); create_model(family(), config(), ctx)
  // rebuilds the same architecture.
  virtual nlohmann::json config() const = 0;

  // Called by the trainer before every training step (1-based step of total_steps), so a family
  // can schedule loss weights (e.g. KL annealing) without trainer special cases. Default: no-op.
  virtual void set_progress(int step, int total_steps) {}

  // Training objective on a batch. Uses training-only regularisers (e.g. data dropout) only when
  // is_training(). Random choices draw from the default CPU generator (torch::manual_seed).
  virtual LossTerms loss(const Batch& batch) = 0;

  // Random motion for request.control: returns [B, T, D] standardised poses, one per control
  // frame. Deterministic given the request (seed included); no gradient is recorded.
  virtual torch::Tensor sample(const SampleRequest& request) = 0;

  // Seconds of standing (zero control) that offline sampling generates first and drops when the
  // caller leaves the choice to the family (nn::kFamilyWarmup; mosyn sample / eval without
  // --warmup). Families that start from a neutral initial state need it to settle into a natural
  // pose (MoGlow: the mean pose as history, 1 s); 0 for those whose first frames are already
  // natural (the recurrent VAE, whose first latent comes from the prior or the posterior).
  virtual double default_warmup_s() const { return 0.0; }

  // True when content and style labels of SampleRequest / Batch condition the motion; a family
  // that ignores labels refuses requests that carry them (nn/sampling.h).
  virtual bool takes_labels() const { return false; }

  // Causal models support frame-by-frame generation with no algorithmic latency.
  virtual bool supports_streaming() const { return false; }
  // Starts a stream from the request's prefix, labels, temperature and seed (request.control is
  // ignored; the batch size comes from prefix_pose, content, style or request.batch).
  virtual std::unique_ptr<StreamState> begin_stream(const SampleRequest& request);
  // Advances a stream by one frame: control [B, C] standardised of the new frame t (the delta
  // t-1 -> t) gives pose [B, D] standardised of frame t.
  virtual torch::Tensor step_stream(StreamState& state, const torch::Tensor& control);
};

using ModelFactory =
    std::function<std::shared_ptr<MotionModel>(const nlohmann::json& config, const ModelContext& context)>;

// Builds a model of a family ("moglow", ...) from a (possibly partial) config; missing keys take
// the family's defaults; a "preset" key selects a named set of defaults first. Parameters are
// initialised from the default torch generator (call torch::manual_seed first for
// reproducibility). Throws mosyn::Error for an unknown family, unknown key or invalid value.
std::shared_ptr<MotionModel> create_model(const std::string& family, const nlohmann::json& config,
                                          const ModelContext& context);

// Families create_model knows, sorted.
std::vector<std::string> model_families();

// Adds a family to the registry (replacing one of the same name).
void register_model_family(const std::string& family, ModelFactory factory);

// Sets the number of intra-op CPU threads LibTorch uses; threads <= 0 means all cores.
// Returns the number set.
int set_num_threads(int threads);

// "cpu" or "cuda"/"cuda:N" to a torch::Device; throws mosyn::Error when CUDA is asked for but
// not available.
torch::Device parse_device(const std::string& device);

}  // namespace mosyn::nn
