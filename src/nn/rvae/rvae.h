// Recurrent variational autoencoder for controllable motion synthesis ("VAE-LSTM"):
// Habibie, Holden, Schwarz, Yearsley & Komura, "A Recurrent Variational Autoencoder for Human
// Motion Synthesis" (BMVC 2017), /work/shared/papers/habibie2017-recurrent-vae.txt.
// Family name "rvae". See src/nn/rvae/README.md for the full description and the choices made
// where the paper is silent.
//
//   pose    [B, T, D] --pad--> [B, T', D], T' = multiple of R = 2^num_blocks
//     inference network: (Conv1d k 'same' -> ELU -> MaxPool1d(2)) x num_blocks, then a 1x1 conv
//     head -> mean, logvar [B, L, Z], L = T'/R reduced steps
//   control [B, T, C] --pad--> control encoder of the same form (no head) -> h_c [B, L, Hc]
//   decoder cell (paper Eqs. 7-9), cell state of size Z:
//     s_t = z_t (teacher_latent: the state is SET to the latent) or c_{t-1} (free running)
//     i_t = sigmoid(W_ic s_t + W_ih h_c,t),  f_t = sigmoid(W_fc s_t + W_fh h_c,t)
//     c_t = ELU(f_t * W_c s_t + i_t * W_h h_c,t)
//   canvas [B, L, Z] = the cell states over time
//   deconvolution network: (Upsample x2 -> Conv1d k 'same' [-> ELU]) x num_blocks -> [B, T', D],
//     cropped to [B, T, D]
// All tensors standardised (nn/model.h conventions).
#pragma once

#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>

#include <ATen/core/Generator.h>

#include <memory>
#include <utility>
#include <string>
#include <vector>

#include "nn/objectives/foot_objectives.h"
#include "nn/model.h"

namespace mosyn::nn {

// Hyper-parameters; JSON keys are the field names. Defaults follow the paper (Sec. 4.2) except
// where noted in the README.
struct RvaeOptions {
  std::vector<int> encoder_channels = {64, 256};  // inference-network conv channels per block
  std::vector<int> control_channels = {64, 128};  // control-encoder conv channels per block (last = Hc)
  std::vector<int> decoder_channels = {128};      // hidden deconv channels (num_blocks - 1 entries)
  int latent = 128;            // Z: latent size = decoder cell-state size (LSTM units)
  int kernel = 25;             // temporal kernel width of every conv (odd, 'same' padding)
  double input_dropout = 0.1;  // dropout on the encoders' inputs (pose and control), training only
  double kl_weight = 1.0;      // weight of the KL term once annealing is over
  double kl_anneal = 0.0;      // fraction of the training steps over which the KL weight ramps
                               // linearly from 0 to kl_weight (0 = no annealing, as the paper)
  double l1 = 0.0;             // L1 penalty on the weights (sum |w| x l1, added to "loss")
  // Latents at generation time (training always sets every step's state to a latent):
  // "first" = one latent for the first reduced step, then the cell runs freely (Algorithm 1);
  // "every_step" = a fresh prior latent sets the state of every step after the prefix (the
  // alternative the paper reports works equally well, Sec. 3.4). Changing it needs no retraining.
  std::string test_latents = "first";
  // Content and style labels as conditions: one-hot, appended to the control encoder's input at
  // every frame (nn/label_features.h). Off in runs made before labels were supported.
  bool labels = false;
  double label_dropout = 0.1;  // training: probability that a window's label is replaced by none
  // Training: probability that a reduced step after the first runs from the previous cell state
  // instead of being set to its latent (its KL is then not counted: the latent is unused). The
  // paper trains with every step set to its latent (0) but samples with the cell running freely
  // after the first (Algorithm 1), a mode training never exercises; 1 trains exactly the model
  // Algorithm 1 samples from. See the README.
  double free_running = 0.0;
  // Prior of the per-step latents. "standard": N(0, I) for every reduced step (the paper).
  // "conditional": step 1 from N(0, I), step k > 1 from a learned Gaussian p(z_k | c_{k-1}, h_c,k)
  // of the previous cell state and the step's control code (the learned prior of a VRNN, Chung et
  // al. 2015), so latents drawn at generation time continue the gait the cell is in instead of
  // restarting it at random; training minimises KL(q(z_k | x) || p(z_k | ...)). See the README.
  std::string latent_prior = "standard";
  int prior_hidden = 256;       // width of the conditional prior's hidden layer
  // The shared foot objectives (beyond the paper; nn/objectives/foot_objectives.h), on the
  // reconstruction of each training window against the window, with the data's root steps: planted
  // heels (foot_contact_weight), heel speeds (heel_speed_weight), toe slide (toe_slide_weight: asked
  // for the held-out takes' own styles, a model trained without it slid its toes 1.3x the takes'),
  // and the others. Their keys sit at the top level of the config; every weight 0 = off (the
  // paper's loss).
  FootObjectiveOptions foot;

  int num_blocks() const { return static_cast<int>(encoder_channels.size()); }
  int reduction() const { return 1 << num_blocks(); }  // R: frames per reduced step

  // Overrides of the defaults; throws mosyn::Error on an unknown key or a bad value.
  static RvaeOptions from_json(const nlohmann::json& config);
  nlohmann::json to_json() const;
};

// Conv1d('same') -> ELU -> MaxPool1d(2) blocks, optionally followed by a 1x1 conv head.
// forward: x [B, T', F] with T' a multiple of 2^blocks -> [B, T'/2^blocks, out] (batch-first).
class ConvEncoderImpl : public torch::nn::Module {
 public:
  ConvEncoderImpl(int in_dim, const std::vector<int>& channels, int kernel, int head_dim /* 0 = none */);
  torch::Tensor forward(const torch::Tensor& x);
  torch::nn::ModuleList convs;
  torch::nn::Conv1d head{nullptr};
};
TORCH_MODULE(ConvEncoder);

// The paper's modified LSTM cell (Eqs. 7-9); no output gate: the cell state is the output.
class RvaeCellImpl : public torch::nn::Module {
 public:
  RvaeCellImpl(int state_dim, int control_dim);
  // prev [B, Z] previous cell state c_{t-1}; control [B, Hc] encoded control h_c,t;
  // latent [B, Z] z_t. teacher_latent = true: the state entering the step is the latent
  // (training, Eq. 9 top; prev is ignored); false: it is prev (test time, Eq. 9 bottom; latent
  // ignored, may be undefined). Returns c_t [B, Z].
  torch::Tensor forward(const torch::Tensor& prev, const torch::Tensor& control, const torch::Tensor& latent,
                        bool teacher_latent);
  torch::nn::Linear gates_state{nullptr};    // [W_ic; W_fc] (with b_ic, b_fc)
  torch::nn::Linear gates_control{nullptr};  // [W_ih; W_fh] (with b_ih, b_fh)
  torch::nn::Linear state_in{nullptr};       // W_c (no bias)
  torch::nn::Linear control_in{nullptr};     // W_h (no bias)
};
TORCH_MODULE(RvaeCell);

class RvaeImpl : public MotionModel {
 public:
  RvaeImpl(const RvaeOptions& options, const ModelContext& context);

  std::string family() const override { return "rvae"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const RvaeOptions& options() const { return options_; }

  // KL annealing: weight = kl_weight * min(1, step / (kl_anneal * total_steps)).
  void set_progress(int step, int total_steps) override;
  double current_kl_weight() const { return kl_now_; }

  // Negative ELBO with one posterior sample per reduced step (reparameterised, default CPU
  // generator), decoder in teacher_latent mode. Terms (nats per frame, standardised space):
  // "recon" Gaussian NLL with unit variance, 0.5 sum_d (x - x_hat)^2 + D/2 log(2 pi);
  // "kl" sum over latent dims and reduced steps of KL(q || N(0, I)), divided by T;
  // "nll_frame" = recon + kl (the negative ELBO per frame, an upper bound of the NLL);
  // "nll_dim" = nll_frame / D; "kl_weight"; "loss" = (recon + w kl) / D (+ l1 penalty) with
  // w the annealed weight in training and kl_weight in eval (so validation is comparable).
  LossTerms loss(const Batch& batch) override;
  // The control encoder's first convolution takes [control, labels] per frame.
  std::vector<LabelInput> label_inputs() const override;

  // control [B, T, C], any T >= 1. Without prefix_pose: z_1 ~ N(0, temperature^2 I) (prior,
  // the paper's Algorithm 1). With prefix_pose [B, P, D] (and prefix_control [B, P, C], zeros =
  // mean control when undefined): the prefix is encoded, its K = ceil(P / R) reduced steps take
  // z_k = mu_k + temperature sigma_k eps (teacher_latent), and the P prefix frames are cropped
  // from the output. The remaining steps run freely (test_latents "first") or each take a fresh
  // z ~ N(0, temperature^2 I) in teacher mode ("every_step"). Returns poses [B, T, D] and
  // request.control.
  SampleOutput sample(const SampleRequest& request) override;
  // Takes control, labels (when trained with them) and prefixes; offline only (the deconvolution
  // decoder sees the future); no warm-up (the first latent comes from the prior or the prefix).
  ModelTraits traits() const override;

  struct Posterior {
    torch::Tensor mean;    // [B, L, Z]
    torch::Tensor logvar;  // [B, L, Z]
  };
  // pose [B, T, D] (any T >= 1; padded internally to a multiple of R by repeating the last
  // frame) -> posterior of the L = ceil(T / R) reduced steps.
  Posterior encode(const torch::Tensor& pose);
  // control [B, T, C] -> h_c [B, ceil(T / R), Hc]. labels [B, label_dim()] (label_features;
  // undefined = none) join the control at every frame when the model takes labels.
  torch::Tensor encode_control(const torch::Tensor& control, const torch::Tensor& labels = {});
  int label_dim() const { return label_dim_; }
  // Runs the cell over the L reduced steps: h_c [B, L, Hc]; latents [B, K, Z] (K >= 1). Steps
  // k < K use latents[k] as the state entering the step (teacher_latent); steps k >= K run
  // from the previous cell state. K = L is the training mode. use_latent (optional [B, K] bool,
  // step 0 must be true) lets a row run from its previous state at a step < K where it is false.
  // Returns the canvas [B, L, Z].
  torch::Tensor run_decoder(const torch::Tensor& control_code, const torch::Tensor& latents,
                            const torch::Tensor& use_latent = {});
  // Conditional prior (latent_prior "conditional"): mean and log-variance [B, Z] of z_k given the
  // previous cell state prev [B, Z] and the step's control code [B, Hc].
  std::pair<torch::Tensor, torch::Tensor> conditional_prior(const torch::Tensor& prev, const torch::Tensor& control_code);
  // The decoder with the conditional prior: steps k < K are set to latents[k] (and, with
  // prior_out, the prior of every step k >= 1 is returned: mean, logvar [B, L - 1, Z]); steps
  // k >= K draw z_k = mean + temperature * std * eps from the prior with generator gen.
  torch::Tensor run_decoder_conditional(const torch::Tensor& control_code, const torch::Tensor& latents,
                                        double temperature, at::Generator* gen,
                                        std::pair<torch::Tensor, torch::Tensor>* prior_out = nullptr);
  bool conditional() const { return options_.latent_prior == "conditional"; }

  // canvas [B, L, Z] -> poses [B, L * R, D] (the caller crops).
  torch::Tensor decode_canvas(const torch::Tensor& canvas);
  // Closed-form KL(N(mean, exp(logvar)) || N(0, I)) summed over the last dimension: [B, L].
  static torch::Tensor kl_to_unit_gaussian(const torch::Tensor& mean, const torch::Tensor& logvar);
  // [B, T, F] -> [B, ceil(T / R) * R, F] repeating the last frame.
  torch::Tensor pad_time(const torch::Tensor& x) const;

  ConvEncoder inference{nullptr};
  ConvEncoder control_encoder{nullptr};
  RvaeCell cell{nullptr};
  torch::nn::ModuleList deconvs;
  torch::nn::Linear prior_hidden{nullptr}, prior_out{nullptr};  // conditional prior only

 private:
  // loss() in parts. The encoders' inputs with element-wise input dropout (training only).
  std::pair<torch::Tensor, torch::Tensor> dropped_inputs(const torch::Tensor& pose, const torch::Tensor& control) const;
  // [B, L] 1 where a reduced step is set to its latent (free_running); undefined = every step.
  torch::Tensor latent_use_mask(const torch::Tensor& latents) const;
  // KL per frame [] of the posterior against the prior of each step (unit Gaussian for the first
  // step and for the standard prior; the learned prior after it), unused latents costing nothing.
  torch::Tensor kl_per_frame(const Posterior& post, const std::pair<torch::Tensor, torch::Tensor>& prior,
                             const torch::Tensor& use_latent, int64_t frames) const;
  // The L1 weight penalty (options_.l1) over every weight matrix, training only.
  torch::Tensor l1_penalty(const torch::TensorOptions& options);

  RvaeOptions options_;
  ModelContext context_;
  double kl_now_ = 1.0;
  int label_dim_ = 0;
  FootObjectives foot_;  // the shared foot terms (options_.foot)
};
TORCH_MODULE(Rvae);


}  // namespace mosyn::nn
