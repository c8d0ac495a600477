// MoGlow (Henter, Alexanderson & Beskow 2020): an autoregressive, controllable normalising flow
// for motion. The distribution of the next pose x_t [D] given the previous tau poses, the controls
// of frames t-tau..t and a recurrent state is a conditional Glow of K steps:
//
//   x_t = z_{t,0} -> [ActNorm -> invertible linear (LU) -> affine coupling (LSTM)] x K -> z_t ~ N(0, I)
//
// All tensors here are standardised poses/controls (see nn/model.h). Inside the flow, sequences
// are time-major [T', B, .] (T' = predicted frames) because the coupling LSTMs run over time.
// The log-determinants returned below are of the normalising direction (x -> z), per frame.
#pragma once

#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>

#include <c10/util/Optional.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <tuple>
#include <vector>

#include "nn/objectives/foot_objectives.h"
#include "nn/model.h"
#include "nn/moglow/pose_transport.h"

namespace mosyn::nn {

// Hyper-parameters. JSON keys are the field names. Presets: "default" (the shipped model) and
// "paper" (Sec. 4.2 of the paper: K=16, two 512-unit LSTM layers, tau=10).
struct MoGlowOptions {
  std::string preset = "default";
  int num_steps = 8;        // K, steps of flow
  int hidden = 256;         // LSTM units per layer in each coupling network
  int lstm_layers = 1;      // LSTM layers per coupling network
  int tau = 10;             // frames of pose history (and tau+1 frames of control) conditioned on
  double dropout = -1.0;    // data dropout probability of whole history frames in training;
                            // < 0 = by pose form: 0.95 positions, 0.6 rotations (paper)
  double scale_eps = 0.05;  // coupling scale s = sigmoid(h + 2) + scale_eps, in (eps, 1 + eps)
  // Content and style labels as conditions (one-hot, appended to the conditioning vector of
  // every frame; nn/label_features.h). Off in runs made before labels were supported.
  bool labels = false;
  double label_dropout = 0.1;  // training: probability that a window's label is replaced by none
  // Optional look-ahead of the path, as real-time character controllers use: for each offset k
  // (frames), the mean control over frames t+1..t+k (where the path goes next: displacement and
  // turn per frame; past the end of the control, its last frame repeats). Empty = causal (the
  // paper). Offline sampling reads the real path ahead; a stream reads the path a controller
  // predicts from the input so far (MotionModel::step_stream_ahead), so it stays causal.
  std::vector<int> lookahead;
  // Training, with look-ahead: the probability that a window's look-ahead features are read from
  // the path a real-time controller would predict at each frame instead of the path's real future,
  // so that the model learns what it reads when it streams (data/root_controller.h: a critically
  // damped filter of the control with natural frequency 1.31 / prediction_smoothing_s, its input
  // held). At frame t the filter stands at the data's control c_t moving by c_t - c_{t-1}, and its
  // input is the control one filter delay later, c_{t + round(2 / omega)} (the centroid of the
  // filter's impulse response: a game's input shows up in the filtered root that much later).
  // 1 = always, also in validation (its loss then scores the run-time input); 0 = the real future.
  double predicted_lookahead = 0.0;
  // The filter's Gaussian-equivalent sigma (seconds); <= 0 = the dataset's root_smoothing_s, which
  // the runtime's controller matches (nn/generator.h GeneratorOptions::control_smoothing_s).
  double prediction_smoothing_s = 0.0;
  // Clips shorter than the training window join training as one window each, padded with their
  // last frame, the padding masked out of the loss (exact: the flow is causal, so padding after
  // a frame cannot change its likelihood). false = left out, as runs before this option.
  bool short_clips = true;
  // Residual parameterisation (positions form only; not in the paper): the flow models
  // x_t - T(x_{t-1}, c_t), where T carries the previous frame's joints into frame t's root frame
  // (pose_transport.h), instead of x_t itself. A shift by a function of the condition has unit
  // Jacobian, so this is still the exact likelihood of x_t; but a planted foot becomes a residual
  // of 0 instead of a copy of the previous frame minus the root's step that the coupling networks
  // must learn. The transport always takes the true previous frame (data dropout still hides it
  // from the conditioning).
  bool residual = false;
  // Training only: standard deviation (standardised feature units) of Gaussian noise added to the
  // poses the model conditions on (the history and the residual's previous frame), not to the
  // frames it scores, so it learns to pull its own slightly-off poses back (with `residual`, the
  // error of each frame would otherwise carry on into the next). 0 = off (the paper).
  double history_noise = 0.0;
  // Sampling: seconds generated first along the control's first step and dropped when no prefix is
  // given and the caller leaves the choice to the family (ModelTraits::default_warmup_s, `--warmup`).
  // From the mean pose the model needs time to settle into the gait: the paper pre-generates 1 s;
  // a model whose fast gaits settle later records a longer lead-in here, so that its run directory
  // samples as it was measured (models/moglow-lookahead: 3 s).
  double lead_in_s = 1.0;
  // Training only: the shared foot objectives (nn/objectives/foot_objectives.h: planted heels,
  // heel speed, lift-off, stance, speed distribution, toe slide, pelvis, bone lengths), their keys
  // at the top level of the config. MoGlow computes them on frames drawn from the flow, not on the
  // likelihood's teacher-forced frames: the likelihood alone leaves planted feet gliding
  // (models/moglow-lookahead/README.md). Every weight 0 = off (the paper).
  FootObjectiveOptions foot;
  // Frames the terms' draws run free: 0 = every frame of the window drawn at once under the true
  // history (temperature foot_contact_temperature); k > 0 = k frames generated one by one after the
  // window's first tau true frames, each conditioned on the draws before it, as in sampling (the
  // glide of a model fed its own history).
  int foot_contact_rollout = 0;
  double foot_contact_temperature = 1.0;  // latent standard deviation of the terms' draws
  // The phase-locked foot terms (planted, speed error, lingering) read the first this many draws of
  // the rollout only; 0 = all. The stance, speed-distribution, toe and pelvis terms read them all.
  int phase_locked_frames = 0;
  // With foot_contact_rollout > 0: the share of a batch's windows (its first rows) whose draws
  // start from the mean pose as history, as sampling without a prefix does (then a lead-in along the
  // control's first step), instead of from the window's first tau frames. Such a start has no phase
  // of the data's, so the phase-locked terms leave those rows out; the others read them. From the
  // mean pose at 3 m/s the shipped model's legs stopped cycling within a second or two, from a real
  // run's first half second they did not. 0 = off.
  double cold_start_fraction = 0.0;
  // Whether training draws frames for the foot terms (any weight is on).
  bool heel_terms_on() const { return foot.any_on(); }

  // Resolves preset, then overrides; throws mosyn::Error on an unknown key or bad value.
  static MoGlowOptions from_json(const nlohmann::json& config, const ModelContext& context);
  nlohmann::json to_json() const;
};

// (h, c) of a torch LSTM, each [layers, B, hidden].
using LstmState = std::tuple<torch::Tensor, torch::Tensor>;

// Activation normalisation: y = (x + bias) * exp(logs) per dimension; log|det| = sum(logs)
// per frame. Data-dependent initialisation (initialize) makes the first batch's output zero-mean,
// unit-variance per dimension; the "initialized" buffer persists it through checkpoints.
class ActNormImpl : public torch::nn::Module {
 public:
  explicit ActNormImpl(int dim);
  // x [..., D] -> y [..., D].
  torch::Tensor forward(const torch::Tensor& x);
  torch::Tensor reverse(const torch::Tensor& y);
  // Scalar log|det dy/dx| of one frame.
  torch::Tensor logdet() const;
  bool initialized() const;
  // Sets bias = -mean(x), logs = -log(std(x) + 1e-6) over all leading dims of x [..., D].
  void initialize(const torch::Tensor& x);

  torch::Tensor bias, logs, initialized_flag;
};
TORCH_MODULE(ActNorm);

// Invertible linear map b = W a with W = P L U: P a fixed permutation, L unit lower-triangular,
// U upper-triangular with diagonal sign * exp(log_s); log|det W| = sum(log_s). Initialised from
// a random orthogonal matrix (as Glow).
class InvLinearImpl : public torch::nn::Module {
 public:
  explicit InvLinearImpl(int dim);
  torch::Tensor weight() const;  // W [D, D]
  // a [..., D] -> a W^T.
  torch::Tensor forward(const torch::Tensor& a);
  // b [..., D] -> b W^-T, with w_inverse = W^-1 computed once by the caller (weight().inverse()).
  torch::Tensor reverse(const torch::Tensor& b, const torch::Tensor& w_inverse);
  torch::Tensor logdet() const;

  torch::Tensor lower, upper, log_s;          // parameters
  torch::Tensor perm, sign_s, lower_mask, eye;  // fixed buffers
};
TORCH_MODULE(InvLinear);

// Affine coupling: with b = [b_lo (first floor(D/2) dims), b_hi],
//   [shift, h] = Linear(LSTM([b_lo, cond])),  s = sigmoid(h + 2) + eps,
//   z = [b_lo, (b_hi + shift) * s],  log|det| = sum(log s) per frame.
// The LSTM runs over time (time-major) and its state is carried through `state` (nullopt = zeros).
// The final Linear is zero-initialised so the coupling starts near the identity.
class CouplingImpl : public torch::nn::Module {
 public:
  CouplingImpl(int dim, int cond_dim, int hidden, int layers, double scale_eps);
  // b [T, B, D], cond [T, B, cond_dim] -> (z [T, B, D], logdet [T, B]); updates state.
  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& b, const torch::Tensor& cond,
                                                   c10::optional<LstmState>& state);
  // z [T, B, D] -> b; updates state exactly as forward would on the returned b.
  torch::Tensor reverse(const torch::Tensor& z, const torch::Tensor& cond, c10::optional<LstmState>& state);

  int dim_lo() const { return d_lo_; }

  torch::nn::LSTM lstm{nullptr};
  torch::nn::Linear out{nullptr};

 private:
  std::tuple<torch::Tensor, torch::Tensor> shift_scale(const torch::Tensor& lo, const torch::Tensor& cond,
                                                       c10::optional<LstmState>& state);
  int dim_, d_lo_;
  double eps_;
};
TORCH_MODULE(Coupling);

// One step of flow: ActNorm, InvLinear, Coupling.
class FlowStepImpl : public torch::nn::Module {
 public:
  FlowStepImpl(int dim, int cond_dim, int hidden, int layers, double scale_eps);
  // x [T, B, D] -> (z [T, B, D], logdet [T, B]).
  // initialize_actnorm: data-dependent ActNorm initialisation from x if not yet initialised.
  std::tuple<torch::Tensor, torch::Tensor> forward(const torch::Tensor& x, const torch::Tensor& cond,
                                                   c10::optional<LstmState>& state,
                                                   bool initialize_actnorm = false);
  torch::Tensor reverse(const torch::Tensor& z, const torch::Tensor& cond, c10::optional<LstmState>& state,
                        const torch::Tensor& w_inverse);

  ActNorm actnorm{nullptr};
  InvLinear linear{nullptr};
  Coupling coupling{nullptr};
};
TORCH_MODULE(FlowStep);

struct MoGlowInference;  // moglow_stream.h

class MoGlowImpl : public MotionModel {
 public:
  MoGlowImpl(const MoGlowOptions& options, const ModelContext& context);

  std::string family() const override { return "moglow"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const MoGlowOptions& options() const { return options_; }
  const ModelContext& context() const { return context_; }

  // Negative log-likelihood (paper Eq. 10) of frames tau..T-1 in standardised space.
  // "loss" = nll_dim (mean over frames, batch and dims; scale-free across D and T),
  // "nll_frame" = nats per predicted frame (Gaussian constant included), "nll_dim" = per dim,
  // "logdet_frame" = mean log|det| per frame. Data dropout applies when is_training().
  // The first call in training mode initialises every ActNorm from this batch. Frames past a
  // window's Batch::frames (a short clip's padding) are left out of every term.
  LossTerms loss(const Batch& batch) override;
  // Every coupling LSTM's first layer takes [x_lo, history, control, labels, look-ahead].
  std::vector<LabelInput> label_inputs() const override;
  // With short_clips: clips of more than tau frames (at least one predicted frame).
  int short_window_min_frames() const override { return options_.short_clips ? options_.tau + 1 : 0; }
  // With look-ahead, its longest offset: the look-ahead of a window's last frames reads the path
  // past the window.
  int control_frames_after() const override;

  // Takes control, labels (when trained with them) and prefixes (as the pose history); streams
  // unless it looks ahead; warms up for 1 s from the mean pose.
  ModelTraits traits() const override;
  SampleOutput sample(const SampleRequest& request) override;
  std::unique_ptr<StreamState> begin_stream(const SampleRequest& request) override;
  // The weights rearranged for inference (moglow_stream.h), built once and shared by every stream
  // of the model (a server's connections, a crowd's characters); rebuilt when a parameter has
  // changed since (training between samples). Thread-safe.
  std::shared_ptr<const MoGlowInference> inference();
  StreamFrame step_stream(StreamState& state, const torch::Tensor& control) override;
  StreamFrame step_stream_ahead(StreamState& state, const torch::Tensor& control,
                                const torch::Tensor& control_ahead) override;
  void reseed_stream_row(StreamState& state, int64_t row, std::uint64_t seed) override;
  void copy_stream_row(StreamState& dst, int64_t dst_row, const StreamState& src, int64_t src_row) override;

  // Result of running the normalising direction over a window.
  struct Encoded {
    torch::Tensor z;       // [B, T - tau, D] latents of frames tau..T-1
    torch::Tensor logdet;  // [B, T - tau] sum of log|det| over all steps, per frame
    std::vector<c10::optional<LstmState>> states;  // per flow step, after the last frame
    torch::Tensor cond;    // [T - tau, B, cond_dim()] the conditioning of frames tau..T-1 (time-major)
  };
  // pose [B, T, D], control [B, T, C] standardised, T > tau. history_keep (optional [B, T] of
  // 0/1) multiplies pose frames before they enter the history (data dropout). init_states
  // (optional, per step) continues a previous window. initialize_actnorm: initialise any
  // uninitialised ActNorm from this data (loss() does so in training mode). labels: [B,
  // label_dim()] from label_features (undefined = no labels); ignored when label_dim() is 0.
  // history_offset (optional [B, T, D]) is added to the poses conditioned on (history, the
  // residual's previous frame) but not to the frames scored (history_noise). control_after
  // (optional [B, K, C] standardised, Batch::control_after) continues the control past the window
  // for the look-ahead.
  Encoded encode(const torch::Tensor& pose, const torch::Tensor& control,
                 const torch::Tensor& history_keep = {},
                 const std::vector<c10::optional<LstmState>>* init_states = nullptr,
                 bool initialize_actnorm = false, const torch::Tensor& labels = {},
                 const torch::Tensor& history_offset = {}, const torch::Tensor& control_after = {});

  // The generating direction over a whole window at once, teacher-forced (the history is the
  // data's, through cond): z [T', B, D] and cond [T', B, cond_dim()] (Encoded::cond) -> what the
  // flow models [T', B, D] (x_t standardised, or with `residual` x_t minus the transported previous
  // frame), each coupling LSTM from a zero state. Inverts encode() from zero states exactly; runs
  // parallel over time because a coupling's network sees only the half it leaves unchanged.
  torch::Tensor reverse_window(const torch::Tensor& z, const torch::Tensor& cond);

  // Per-frame log p(x_t | ...) [B, T - tau] (nats) without dropout.
  torch::Tensor log_likelihood(const torch::Tensor& pose, const torch::Tensor& control);

  // Conditioning vectors [T - tau, B, tau*D + (tau+1)*C + label_dim()] (time-major) for frames
  // tau..T-1: concat of poses t-tau..t-1 (oldest first), controls t-tau..t, then the labels
  // [B, label_dim()] (zeros when undefined).
  torch::Tensor conditioning(const torch::Tensor& pose, const torch::Tensor& control,
                             const torch::Tensor& labels = {}, const torch::Tensor& control_after = {}) const;
  // With look-ahead, the control's look-ahead features of frames tau..T-1 are appended last.

  int cond_dim() const { return cond_dim_; }
  // Size of the label part of the conditioning: content + style vocabularies, or 0 without labels.
  int label_dim() const { return label_dim_; }
  // Look-ahead features [B, T, C * lookahead.size()] of a standardised control [B, T, C] (see
  // MoGlowOptions::lookahead); undefined without look-ahead. The path continues with control_after
  // (optional [B, K, C], K >= 0), then its last frame repeats (a path that ends stands there).
  torch::Tensor lookahead_features(const torch::Tensor& control, const torch::Tensor& control_after = {}) const;
  // The same features read from the controller's prediction at every frame
  // (MoGlowOptions::predicted_lookahead): [B, T, C * lookahead.size()].
  torch::Tensor predicted_lookahead_features(const torch::Tensor& control, const torch::Tensor& control_after = {}) const;
  // The prediction filter's natural angular frequency per frame, and its delay in frames.
  double prediction_omega_per_frame() const;
  int prediction_delay_frames() const;
  double dropout() const { return dropout_; }
  // The residual's transport (MoGlowOptions::residual); nullptr when the flow models x_t itself.
  const PoseTransport* transport() const { return options_.residual ? &transport_ : nullptr; }

  std::vector<FlowStep> steps;

 private:
  MoGlowOptions options_;
  ModelContext context_;
  int cond_dim_ = 0;
  int label_dim_ = 0;
  int lookahead_dim_ = 0;
  double dropout_ = 0.0;
  PoseTransport transport_;  // with options_.residual
  // inference()'s cache: the rearranged weights and the parameters' versions they were built from.
  std::shared_ptr<std::mutex> inference_mutex_ = std::make_shared<std::mutex>();
  std::shared_ptr<const MoGlowInference> inference_;
  std::vector<std::pair<const void*, int64_t>> inference_key_;
  FootObjectives foot_;  // the shared terms and their window weights, with options_.heel_terms_on()
  // The heel and pelvis terms of a batch on one set of draws (MoGlowOptions::foot_contact_weight,
  // heel_speed_weight, lift_off_weight, pelvis_follow_weight): scalars in m/s (m for the pelvis).
  // seen = the poses conditioned on [B, T, D], e the window's encoding, valid [B, T'] (undefined =
  // all frames).
  struct HeelTerms {
    // all but planted_mps: undefined when their weight is 0
    torch::Tensor planted_mps, speed_error_mps, lingering_mps, pelvis_offset_m, missed_stance_mps, toe_slide_mps,
        excess_slow_share, speed_distribution_mps, bone_length_error_m;
  };
  // The draws the terms read: made [B, n, D] standardised frames tau..tau+n-1 and prev [B, n, D]
  // the frame before each (n: foot_contact_rollout's draws run free from the window's first tau
  // frames, or the mean pose on the cold-start rows; without it one teacher-forced draw of every
  // predicted frame), warm_rows [B] 1 for the rows started from the data's frames.
  struct HeelDraws {
    torch::Tensor made, prev, warm_rows;
  };
  HeelDraws heel_draws(const Batch& batch, const torch::Tensor& seen, const Encoded& e);
  HeelTerms heel_terms(const Batch& batch, const torch::Tensor& seen, const Encoded& e, const torch::Tensor& frame_valid);
  // The free-running draws of the term (foot_contact_rollout = k > 0): [B, k, D] standardised poses
  // of frames tau..tau+k-1 generated from seen frames 0..tau-1, conditioned as e.cond apart from
  // the history.
  // W^-1 of every step's invertible linear map, in step order (differentiable).
  std::vector<torch::Tensor> linear_inverses() const;
  torch::Tensor rollout(const torch::Tensor& seen, const torch::Tensor& control, const Encoded& e, int64_t k);
  // One generated frame: the stream's history, the frame's control [B, C] and its look-ahead
  // features [B, 3 K] (undefined without look-ahead).
  torch::Tensor next_frame(StreamState& state, const torch::Tensor& control, const torch::Tensor& lookahead);
  // label_features of a request's or batch's labels, [B, label_dim()] (undefined without labels).
  torch::Tensor labels_of(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                          const torch::TensorOptions& options) const;
};
TORCH_MODULE(MoGlow);

}  // namespace mosyn::nn
