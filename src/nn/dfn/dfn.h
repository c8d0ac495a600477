// Dynamic Future Net: Chen, Liu, Ren, Lai, Wang & Yang, "Dynamic Future Net: Diversified Human
// Motion Generation" (ACM MM 2020), /work/shared/papers/chen2020-dynamic-future-net.txt.
// Family name "dfn". See src/nn/dfn/README.md for the description against the paper and every
// choice made where it is silent.
//
//   X_t = [pose_t (D), control_t (C = dx, dz, dtheta)]      standardised, one frame
//   (1) autoencoder "ae" (Sec. 5.1, Eq. 2): z_t = Enc(X_t) (code 16 = pose part + velocity part);
//       pose decoder -> 6D joint rotations -> forward kinematics with the skeleton's bone offsets
//       -> pose features (bone lengths hold by construction); velocity decoder -> control.
//   (2) future embedding "future" (Sec. 5.2, Eq. 3): GRU encoder over z_{t+1..t+H} -> m_t;
//       GRU decoder m_t -> z_hat_{t+1..t+H}; trained on the frozen autoencoder.
//   (3) dynamics "dyn" (Sec. 5.3-5.6, Eq. 15): h_{t+1} = GRU2(h_t, [s_t, f_t]) (two stacked
//       layers); p(f_t | h_t), q(f_t | h_t, m_t); p(m_t | f_t, h_t); p(s_t | m_t, h_t),
//       q(s_t | h_t, z_t, m_t); z_t = MLP(s_t, h_t); TD-VAE term on pairs (t1, t2).
// Trained in three stages through the shared trainer (training_stages / begin_stage).
// All tensors standardised (nn/model.h conventions).
#pragma once

#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>

#include <ATen/core/Generator.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nn/gaussian.h"
#include "nn/model.h"
#include "nn/objectives/draw_objectives.h"
#include "nn/objectives/foot_objectives.h"

namespace mosyn::nn {

// Hyper-parameters; JSON keys are the field names. Paper values where given (Sec. 5), choices
// documented in the README otherwise.
struct DfnOptions {
  int code = 16;            // z: pose-velocity code size (Sec. 6.3: 16)
  int pose_code = 12;       // of which the pose part; the velocity part is code - pose_code
  int ae_hidden = 256;      // width of the autoencoder's MLPs (two hidden layers each)
  bool fk = true;           // decode poses through FK when the context carries a skeleton
  int horizon = 10;         // H: frames of the future the embedding summarises
  int future_hidden = 128;  // GRU width of the future seq2seq network
  int future = 32;          // m: future embedding size
  int state = 128;          // h: deterministic state (two stacked GRU layers, Sec. 5.3: 128)
  int future_latent = 32;   // f: future latent size
  int current_latent = 32;  // s: current latent size
  int prior_f_hidden = 256;  // p(f | h): 3 layers (Sec. 5.3: 256)
  int post_f_hidden = 512;   // q(f | h, m): 2 hidden layers (Sec. 5.4: 512)
  int m_hidden = 128;        // p(m | f, h): 4 layers (Sec. 5.3: 128)
  int prior_s_hidden = 128;  // p(s | m, h): 2 layers (Sec. 5.3: 128)
  int post_s_hidden = 32;    // q(s | h, z, m): 2 hidden layers (Sec. 5.4: 32)
  int z_hidden = 128;        // z = MLP(s, h): 3 hidden layers (Sec. 5.3: 128)
  int td_hidden = 32;        // TD-VAE networks (Sec. 5.5: 32)
  int td_max = 4;            // largest time difference t2 - t1 of the TD term
  double leaky_slope = 0.01;
  // Loss weights.
  double pose_weight = 1.0;      // Eq. 2, pose features
  double velocity_weight = 1.0;  // Eq. 2, root velocity (control)
  double fk_weight = 1.0;        // Eq. 2, joint positions (metres) after FK (rotation features)
  double smooth_weight = 1.0;    // Eq. 3, L_smooth
  // Future stage: start frames per training window whose H-frame futures enter the loss, drawn
  // at random each step (0 = all T - H). Every start costs an H-frame decode through FK, so all
  // 190 of a 200-frame window made this stage 10x slower per step than the others.
  int future_starts = 32;
  double kl_weight = 1.0;        // KL terms of Eq. 15
  // Free bits (Kingma et al. 2016): each of the s and f KL terms, averaged per frame over the
  // batch, enters the loss as max(KL, kl_free_nats), so below that budget nothing pushes a
  // posterior onto its prior. 0 = the paper's plain KL. Against the collapse of s (KL 0.0015 nats
  // per frame after 1,480 steps of the first Bandai-Namco run), which leaves all diversity to f.
  double kl_free_nats = 0.0;
  // Floor on the log-variances of Eq. 15's likelihood terms: p(z | s, h), p(m | f, h) and the
  // TD prediction of s_t2 (its target detached). -8 = only the soft [-8, 8] bound. A variance
  // that shrinks makes its term's gradient grow as 1 / variance. (A divergence seen on
  // Bandai-Namco was not this: the variances stayed near e^-2; a lower lr cured it. README.)
  double observation_logvar_min = -8.0;
  // Scheduled prior draws in the dynamics stage: at each training step and window, with this
  // probability the state advances with s and f drawn from the priors (f ~ p(f | h), m decoded
  // from it, s ~ p(s | m, h)), as at generation, instead of from the posteriors; every loss term
  // is still the posterior's. The later steps then start from states the model's own draws reach,
  // so the priors learn to bring open-loop motion back to the data (scheduled sampling, Bengio et
  // al. 2015, in the latent space). 0 = the paper's training: always the posteriors.
  double prior_rollout = 0.0;
  // Open-loop speed term of the dynamics stage (an addition to the paper, README): after the
  // posterior pass over a training window the model generates rollout_frames more frames from its
  // priors, exactly as step_stream does (reparameterised draws), and the loss adds
  // rollout_speed_weight * [(log(root + e) - log(root* + e))^2 + (log(body + e) - log(body* + e))^2]
  // per window (each ratio counted only beyond rollout_speed_tolerance, below), where root / body
  // are the rollout's mean root and body speed (m/s; window_speeds) and root* / body* the real
  // window's, e = kRolloutSpeedFloorMps. It matches a moment of the motion, not poses, so it does
  // not pull generations to the mean pose; against the slow-down of open-loop walks and runs as the
  // teacher-forced fit sharpens (models/dfn-bandai/README.md).
  // 0 = off (the paper).
  double rollout_speed_weight = 0.0;
  int rollout_frames = 30;
  // Ratio (>= 1) within which the rollout's speeds go unpenalised: each squared log ratio above
  // becomes max(0, |log(a + e) - log(b + e)| - log(tolerance))^2, so a rollout only has to stay
  // within that factor of its window's speed, not match it, and draws keep their spread inside
  // the band. 1 = exact matching (the term as first trained).
  double rollout_speed_tolerance = 1.0;
  // Phase-free foot objectives on the same open-loop rollout (an addition, README): the shared
  // unit's stance (each heel stops once in every run in which the data's does), speed-distribution
  // (heels as slow as the data's for as many steps) and toe-slide terms, the rollout_frames drawn
  // from the priors against the window's last rollout_frames real frames, with the root steps the
  // rollout decodes. Phase-free because a draw's footsteps need not fall where the data's do; the
  // terms on posterior frames (foot) did not reach the priors: continued 750 steps with them, drawn
  // walks still skated 4.4x the takes'. 0 = off.
  double rollout_stance_weight = 0.0;
  double rollout_speed_distribution_weight = 0.0;
  double rollout_toe_slide_weight = 0.0;
  // foot's thresholds with only the three rollout weights above on.
  FootObjectiveOptions rollout_foot() const;
  // Content and style labels as conditions (beyond the paper, which conditions on the prefix
  // alone; README): one-hot labels (nn/label_features.h) enter the priors p(f | h, c), p(s | m, h, c),
  // the posteriors q(f | h, m, c), q(s | h, z, m, c) and the state transition GRU(h, [s, f, c]), so
  // a walk's continuation knows it is a walk for all 30 s and a standing one that it stands. A
  // warm start from an unlabelled run grows those inputs with zero columns: it starts as that run.
  bool labels = false;
  double label_dropout = 0.1;  // training: probability that a window's label is replaced by none
  double m_weight = 1.0;         // log p(m | f, h) of Eq. 15
  double td_weight = 1.0;        // the temporal-difference terms of Eq. 15
  // Stage lengths: fractions of the run's steps (autoencoder, future, dynamics), or, when
  // stage_steps is not empty, its three absolute step counts; a 0 there skips that stage (to
  // continue the dynamics stage of a run whose autoencoder and future network are trained,
  // `--init-from` with stage_steps [0, 0, N]).
  std::vector<double> stage_fractions = {0.3, 0.2, 0.5};
  std::vector<int> stage_steps = {};
  // The shared foot objectives (an addition to the paper; nn/objectives/foot_objectives.h), on the
  // frames the model decodes for each training window with the root steps it decodes for them:
  // the autoencoder's reconstruction in the autoencoder stage, the frames decoded from the
  // posterior's codes (decode_z(s_t, h_t)) in the dynamics stage. Drawn free, the paper's losses
  // left the feet skating 5-6x real walks. Keys at the top level of the config; 0 = off (the paper).
  FootObjectiveOptions foot;

  int velocity_code() const { return code - pose_code; }
  static DfnOptions from_json(const nlohmann::json& config);
  nlohmann::json to_json() const;
};

// MLP: n_hidden Linear + LeakyReLU layers of width `hidden`, then a Linear to `out`.
torch::nn::Sequential dfn_mlp(int in, int hidden, int n_hidden, int out, double slope);

// How the autoencoder's pose decoder makes pose features.
enum class DfnPoseHead {
  kPlain,         // an MLP straight to the features (no skeleton in the context)
  kRotationsFk,   // 6D per joint re-orthogonalised; FK positions for Eq. 2's position term
  kPositionsFk,   // 6D per joint + root translation -> FK with bone offsets -> joint positions
};

// (1) The pose-velocity autoencoder with its FK layer.
class DfnAutoencoderImpl : public torch::nn::Module {
 public:
  DfnAutoencoderImpl(const DfnOptions& o, const ModelContext& context);
  // X [..., D + C] -> z [..., code]
  torch::Tensor encode(const torch::Tensor& x);
  struct Decoded {
    torch::Tensor pose;       // [..., D] standardised features
    torch::Tensor control;    // [..., C] standardised
    torch::Tensor positions;  // [..., J, 3] metres (FK heads only), relative to the trajectory joint
  };
  Decoded decode(const torch::Tensor& z);
  // Joint positions [..., J, 3] (metres) of standardised pose features (FK heads only): for the
  // rotation form FK of the features' rotations relative to the trajectory joint, for the
  // position form the features themselves.
  torch::Tensor feature_positions(const torch::Tensor& pose);
  // Pose features in the data's own units (FK heads: metres and 6D components, as Eq. 2 measures
  // them; the plain head: unchanged, standardised).
  torch::Tensor raw_pose(const torch::Tensor& pose) const;
  // 6D [..., J, 6] + root translation [..., 3] (metres) -> positions [..., J, 3] by FK.
  torch::Tensor fk(const torch::Tensor& rot6d, const torch::Tensor& root) const;
  DfnPoseHead head() const { return head_; }

  torch::nn::Sequential encoder{nullptr}, pose_decoder{nullptr}, velocity_decoder{nullptr};
  torch::Tensor pose_mean, pose_std, offsets;  // buffers (FK heads only): stats, offsets [J, 3] m

 private:
  torch::Tensor rotations_from_features(const torch::Tensor& pose_std_features);  // [..., J, 3, 3]
  DfnPoseHead head_ = DfnPoseHead::kPlain;
  int pose_dim_, control_dim_, pose_code_, joints_ = 0, root_joint_ = 0;
  bool smoothed_ = false;
  std::vector<int> parents_, rot_slot_;  // rot_slot_[j]: first feature of joint j's 6D (-1 none)
  std::vector<int> ancestors_of_root_;
};
TORCH_MODULE(DfnAutoencoder);

// (2) The future-embedding sequence-to-sequence network.
class DfnFutureImpl : public torch::nn::Module {
 public:
  DfnFutureImpl(const DfnOptions& o);
  torch::Tensor embed(const torch::Tensor& codes);               // [N, H, code] -> m [N, future]
  torch::Tensor reconstruct(const torch::Tensor& m, int64_t h);  // m [N, future] -> [N, H, code]
  torch::nn::GRU encoder{nullptr}, decoder{nullptr};
  torch::nn::Linear to_m{nullptr}, from_m{nullptr}, out{nullptr};
};
TORCH_MODULE(DfnFuture);

// (3) The future-guided stochastic latent RNN.
class DfnDynamicsImpl : public torch::nn::Module {
 public:
  // label_dim: width of the one-hot label features c (0 = unlabelled). Every `labels` argument
  // below is c [B, label_dim] (undefined = no label: zeros) and is ignored when label_dim is 0.
  DfnDynamicsImpl(const DfnOptions& o, int label_dim = 0);
  struct Gaussian {
    torch::Tensor mean, logvar;
  };
  static Gaussian split(const torch::Tensor& x);
  Gaussian prior_f(const torch::Tensor& h, const torch::Tensor& labels = {});
  Gaussian posterior_f(const torch::Tensor& h, const torch::Tensor& m, const torch::Tensor& labels = {});
  torch::Tensor decode_m(const torch::Tensor& f, const torch::Tensor& h);
  Gaussian prior_s(const torch::Tensor& m, const torch::Tensor& h, const torch::Tensor& labels = {});
  Gaussian posterior_s(const torch::Tensor& h, const torch::Tensor& z, const torch::Tensor& m,
                       const torch::Tensor& labels = {});
  torch::Tensor decode_z(const torch::Tensor& s, const torch::Tensor& h);
  // One GRU step: state = {h1, h2} -> new state; h_t is the top layer h2.
  std::pair<torch::Tensor, torch::Tensor> step(const std::pair<torch::Tensor, torch::Tensor>& state,
                                               const torch::Tensor& s, const torch::Tensor& f,
                                               const torch::Tensor& labels = {});
  int label_dim() const { return label_dim_; }
  // log p(z | s, h) and log p(m | f, h): Gaussians with a learned per-dimension log-variance
  // (bounded softly to [-8, 8], then floored at observation_logvar_min) around decode_z /
  // decode_m, summed over the last dimension.
  torch::Tensor log_p_z(const torch::Tensor& z, const torch::Tensor& s, const torch::Tensor& h);
  torch::Tensor log_p_m(const torch::Tensor& m, const torch::Tensor& f, const torch::Tensor& h);
  torch::nn::GRUCell gru1{nullptr}, gru2{nullptr};
  torch::Tensor z_logvar, m_logvar;  // parameters [code], [future]
  // The bounded, floored log-variance of a raw parameter z_logvar or m_logvar.
  torch::Tensor observation_logvar(const torch::Tensor& raw) const;
  // logvar floored at observation_logvar_min (unchanged at the default -8).
  torch::Tensor floor_observation_logvar(const torch::Tensor& logvar) const;
  double observation_logvar_min_ = -8.0;
  torch::nn::Sequential prior_f_net{nullptr}, post_f_net{nullptr}, m_net{nullptr}, prior_s_net{nullptr},
      post_s_net{nullptr}, z_net{nullptr}, td_q_net{nullptr}, td_p_net{nullptr};

 private:
  // torch::cat(parts, -1), with the labels (zeros when undefined) appended when label_dim > 0.
  torch::Tensor with_labels(std::vector<torch::Tensor> parts, const torch::Tensor& labels) const;
  int label_dim_ = 0;
};
TORCH_MODULE(DfnDynamics);

class DfnImpl : public MotionModel {
 public:
  DfnImpl(const DfnOptions& options, const ModelContext& context);

  std::string family() const override { return "dfn"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const DfnOptions& options() const { return options_; }

  // Three stages: "autoencoder" (trains ae), "future" (trains future, ae frozen), "dynamics"
  // (trains dyn, ae and future frozen).
  std::vector<TrainingStage> training_stages(const TrainStageDefaults& defaults) const override;
  // The stage's index among the three (by name: skipped stages shift the trainer's index).
  void begin_stage(int index, const TrainingStage& stage) override;
  int stage() const { return stage_; }

  // The current stage's objective (per frame, standardised space); before any stage (-1) the sum
  // of all three. Terms: "loss", "ae_pose", "ae_velocity", "ae_fk", "future_rec", "future_smooth",
  // "nll_z", "z_mse", "nll_m", "kl_s", "kl_f", "td_kl", "td_nll" as the stage computes them; the foot
  // objectives' terms (DfnOptions::foot) in the autoencoder and dynamics stages when on.
  LossTerms loss(const Batch& batch) override;
  LossTerms autoencoder_loss(const Batch& batch);
  LossTerms future_loss(const Batch& batch);
  LossTerms dynamics_loss(const Batch& batch);

  ModelTraits traits() const override;
  // With labels: the first columns of the label block in each labelled input (priors, posteriors,
  // the first GRU layer), for warm starts across vocabularies.
  std::vector<LabelInput> label_inputs() const override;
  // One-hot label features [B, num_content + num_style] of [B] int64 labels (-1 / undefined =
  // none); undefined when the model takes no labels. Throws mosyn::Error for a label outside the
  // vocabularies.
  torch::Tensor labels_of(const torch::Tensor& content, const torch::Tensor& style, int64_t batch,
                          const torch::TensorOptions& options) const;
  // Posterior over the prefix (when given), then T frames from the priors; returns poses and the
  // generated root motion. Equals begin_stream + T step_stream calls.
  SampleOutput sample(const SampleRequest& request) override;
  std::unique_ptr<StreamState> begin_stream(const SampleRequest& request) override;
  StreamFrame step_stream(StreamState& state, const torch::Tensor& control) override;

  // Mean speeds per window, [B] each: the root's from standardised controls [B, T, C] (dx, dz
  // de-standardised with the context's statistics when it has them, metres per frame, times fps),
  // and the body's, the mean over joints and frame pairs of the joint speed relative to the
  // trajectory joint (m/s), from joint positions [B, T, J, 3] in metres (FK heads); the plain head
  // passes standardised pose features [B, T, D] instead and gets their RMS rate per second.
  struct WindowSpeeds {
    torch::Tensor root_mps, body_mps;
  };
  WindowSpeeds window_speeds(const torch::Tensor& control, const torch::Tensor& positions) const;
  // The real speeds' floor in the open-loop speed term (DfnOptions::rollout_speed_weight): below
  // it, differences of standing weight shifts (a few cm/s) weigh little.
  static constexpr double kRolloutSpeedFloorMps = 0.05;

  // Codes of a pose/control sequence [B, T, D], [B, T, C] -> [B, T, code].
  torch::Tensor codes(const torch::Tensor& pose, const torch::Tensor& control);
  // Future windows z_{t+1..t+H} of codes [B, T, K] for t = 0..T-H-1 -> [B, T-H, H, K].
  torch::Tensor future_windows(const torch::Tensor& x) const;

  DfnAutoencoder ae{nullptr};
  DfnFuture future{nullptr};
  DfnDynamics dyn{nullptr};

 private:
  void check_batch(const Batch& batch, int64_t min_frames) const;
  // The open-loop terms of one batch from the state the posterior pass reached: the speed term
  // (DfnOptions::rollout_speed_weight) and the phase-free foot terms (rollout_foot_), weighted and
  // summed; adds their log terms to out (the foot terms' names prefixed "rollout_").
  torch::Tensor rollout_terms(const Batch& batch, std::pair<torch::Tensor, torch::Tensor> state,
                              const torch::Tensor& labels, LossTerms& out);
  // The rollout's foot terms: made [B, R, D] and made_control [B, R, C] against the window's last R frames.
  torch::Tensor rollout_foot_term(const Batch& batch, const torch::Tensor& made, const torch::Tensor& made_control,
                                  LossTerms& out);
  // The foot objectives (DfnOptions::foot) on made poses and root steps [B, n, D], [B, n, C]
  // (standardised, decoded for the window's first n frames) against those frames: the weighted sum
  // (0 outside training or when off); the terms are logged in out.
  torch::Tensor foot_term(const Batch& batch, const torch::Tensor& made, const torch::Tensor& made_control,
                          LossTerms& out);
  int stage_ = -1;
  DfnOptions options_;
  ModelContext context_;
  FootObjectives foot_;
  FootObjectives rollout_foot_;  // DfnOptions::rollout_foot()
};
TORCH_MODULE(Dfn);

}  // namespace mosyn::nn
