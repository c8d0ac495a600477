// Hierarchical deep latent variable model of human motion: Ghorbani, Wloka, Etemad, Brubaker &
// Troje, "Probabilistic Character Motion Synthesis using a Hierarchical Deep Latent Variable
// Model" (SCA 2020), /work/shared/papers/ghorbani2020-hierarchical-latent-variable-model.txt.
// Family name "hvrnn". See src/nn/hvrnn/README.md for the architecture against the paper and
// the choices made where it is silent.
//
//   frames x_t = [pose_t, control_t] (standardised), padded to N = ceil(T / l) words of l frames
//   motion word   w_n = f_enc^w(x_{nl..nl+l-1})              (SL ablation: w_n = the frames)
//   motion cell   a = f_c(labels); h_0 ~ N(mu_label, sigma_label^2) learned per label combination
//                 q(z_n) = N(f_enc^mu(f_w(w_n), h, a), f_enc^sigma(...)^2)        (posterior)
//                 p(z_n) = N(f_prior^mu(h, a), f_prior^sigma(h, a)^2)               (prior)
//                 w~_n = f_dec(f_z(z_n), h, a);  h_n = GRU x 2(f_w(w_n or w~_n), f_z(z_n); h_{n-1})
//   frames        x~ = f_dec^w(w~_n)  (rotations re-normalised by Gram-Schmidt at generation)
// The model generates its own root motion: the control (dx, dz, dtheta) is part of every word.
#pragma once

#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>

#include <ATen/core/Generator.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nn/model.h"
#include "nn/objectives/draw_objectives.h"
#include "nn/objectives/foot_objectives.h"

namespace mosyn::nn {

class ClassifierImpl;

// Hyper-parameters; JSON keys are the field names. Defaults follow the paper (Table 1, Sec. 3-4)
// except where the README says otherwise.
struct HvrnnOptions {
  std::string preset = "full";   // "full", "SL" (no word coder), "NL" (all alpha 1), "NC" (no classifier)
  int word_length = 3;           // l: frames per motion word
  bool word_coder = true;        // f_enc^w / f_dec^w (false = SL: frames enter the cell directly)
  int word_hidden = 128;         // width of the word coder's two hidden layers
  int word_code = 96;            // D_w: motion-word size
  int feature_hidden = 128;      // width of f_w, f_z, f_dec hidden layers (two each)
  int feature = 96;              // output size of f_w and f_z
  int latent = 96;               // D_z
  int gaussian_hidden = 128;     // width of the posterior / prior MLPs
  int gaussian_layers = 4;       // hidden layers of the posterior / prior MLPs
  int state = 512;               // units of each GRU cell
  int state_layers = 2;          // stacked GRU cells (state h = their concatenation)
  int label_code = 8;            // D_a: size of the label features a = f_c(labels)
  double label_dropout = 0.1;    // training: probability a window's label is replaced by none
  double init_std = 0.1;         // initial spread of the learned initial-state Gaussians
  std::string alpha = "hierarchical";  // joint weights: "hierarchical" (Eq. 23) or "uniform" (NL)
  double alpha_floor = 0.1;      // leaf joints weigh at least this fraction of the largest alpha
  double root_weight = 1.0;      // weight of the squared error on the non-rotation channels
  double kl_weight = 1.0;        // lambda_KL after annealing
  double kl_warmup = 0.1;        // fraction of training with lambda_KL = 0
  double kl_anneal = 0.4;        // fraction over which lambda_KL then ramps linearly to kl_weight
  // Free bits (Kingma et al. 2016; not in the paper): the KL per valid frame, averaged over the
  // batch, enters the loss as max(KL, kl_free_nats), so below that budget nothing pushes the
  // posterior onto the prior. 0 = the paper's plain KL. Against the latent's collapse (0.016 nats
  // per frame after 2,650 steps), which leaves generation nearly deterministic given the labels.
  double kl_free_nats = 0.0;
  // Frame-to-frame continuity (not in the paper): 0.5 ||(x_t - x_{t-1}) - (y_t - y_{t-1})||^2 on the
  // standardised features of consecutive valid frames. Each word is decoded from its own state and
  // latent, so without it generated motion steps at every word boundary (measured: a second
  // difference 2.6x larger across boundaries than within words). 0 = the paper.
  double velocity_weight = 0.0;
  // The word decoder also sees the frame before its word (not in the paper): [previous standardised
  // frame, 1], or zeros for a word with none before it. Teacher-forced training gives it the real
  // previous frame; generation, the last frame it made. Each word is otherwise decoded from its own
  // code alone, and consecutive words disagree where they meet (measured on run 3: a second
  // difference of 9 mm across word boundaries against 3.4 inside words, also at temperature 0).
  // Warm starts from a run without it (--init-from) grow the decoder's first layer with zero
  // weights, so training begins from the old model. Needs word_coder.
  bool decoder_previous_frame = false;
  // Boundary term (not in the paper): in training each word n > 0 is decoded a second time from a
  // latent drawn from the prior (as generation does) and the reconstruction error of its first
  // frame enters the loss with this weight. Teacher-forced words come from the posterior, so the
  // other terms never see the words generation makes; their first frame, one frame after a known
  // one, should still continue it. 0 = the paper.
  double boundary_weight = 0.0;
  double validity_weight = 0.1;  // lambda_Ang (Eq. 25 for 6D: ||A^T A - I||^2 before Gram-Schmidt)
  std::string classifier_run;    // run directory of a trained classifier for Eq. 24 ("" = term off)
  double classifier_weight = 0.1;       // lambda_CL at the end of its ramp
  double classifier_ramp = 0.5;         // fraction of training over which lambda_CL grows from 0
  double classifier_feature_weight = 1.0;  // beta of the feature-layer l2 term (CE has beta 1)
  double word_drop = 0.3;        // final probability a teacher-forced word is replaced by the model's own
  double word_drop_ramp = 0.8;   // fraction of training over which it grows linearly from 0
  double spread_floor = 1e-4;    // added to every softplus spread
  // The shared foot objectives (not in the paper; nn/objectives/foot_objectives.h) on each training
  // window's reconstruction, its feet after forward kinematics moving with the root steps the model
  // reconstructs: drawn free, the paper's loss left the feet skating 5-6x real walks. Their keys sit
  // at the top level of the config; every weight 0 = off (the paper).
  FootObjectiveOptions foot;
  // The shared terms on free draws (nn/objectives/draw_objectives.h; not in the paper): every word
  // also decoded from a prior draw at its teacher-forced state (as the boundary term does), the
  // sequence of drawn words against the window: phase-free stance, speed distribution, toe slide
  // and root speed. The foot terms on the reconstruction alone left drawn walks skating 3.8x real
  // ones (docs/experiments.md): they reach the decoder, not the prior samples come from.
  DrawObjectiveOptions draw;
  // The drawn words of the draw terms decoded one after another, each seeing the last frame of the
  // drawn word before it, as generation decodes them (decode_generated), instead of the real frame
  // before it: the terms then see the jumps where generated words meet (a planted heel moved 2-3 cm
  // every third frame in drawn walks, splitting each stance in two). Needs decoder_previous_frame.
  bool draw_chained = false;
  // Generation only (not in the paper): each generated word is joined to the frames before it. The
  // mismatch of its first frame with the continuation of the last two (their velocity averaged with
  // the word's own first one) is added to the word and decays by this factor a frame. Against the
  // planted heel that moves 2-3 cm where words meet, splitting each stance in two. Measured on the
  // shipped model with root planting: at 0.6 walks' mean step went from 0.56x real to 0.72-0.95x,
  // but Table 2's FID from 363 to 464 and content recognised from 54 to 52%, so it ships off.
  // 0 = off (the paper; training never blends).
  double boundary_blend = 0.0;

  static HvrnnOptions from_json(const nlohmann::json& config);
  nlohmann::json to_json() const;
};

// Where the rotations are in the pose features and how heavily each weighs (rotations form with a
// known skeleton, layout and statistics; otherwise the loss falls back to squared error).
struct HvrnnGeometry {
  bool valid = false;
  int num_joints = 0;                // J rotation slots: features [1 + 6k, 1 + 6k + 6)
  std::vector<int> slot_joint;       // [J] skeleton joint of slot k (root joint first)
  std::vector<int> other_dims;       // pose dims that are not rotations (height, root offsets)
  std::vector<double> alpha;         // [J] per slot
  torch::Tensor mean, std;           // [D] pose statistics (float)
};

namespace hvrnn {

// Eq. 23: alpha_k = max over children j of (alpha_j + |bone k-j|), 0 at leaves; then every alpha is
// raised to at least floor_fraction x the largest and all are divided by their mean (mean 1).
// bone_lengths[j] = length of the bone from parents[j] to j (the root's is ignored).
std::vector<double> hierarchical_alphas(const std::vector<int>& parents, const std::vector<double>& bone_lengths,
                                        double floor_fraction);
// Geometry of a context (HvrnnGeometry::valid false when it is not rotations with data attached).
HvrnnGeometry geometry_for(const ModelContext& context, const HvrnnOptions& options);
// Mean over valid consecutive frame pairs of 0.5 ||(p_t - p_{t-1}) - (y_t - y_{t-1})||^2: pred,
// target [B, T, F], mask [B, T] (1 on valid frames, which form a prefix; a pair counts when its
// later frame is valid) -> scalar; 0 when T < 2.
torch::Tensor velocity_error(const torch::Tensor& pred, const torch::Tensor& target, const torch::Tensor& mask);
// sum_k alpha_k d(R(a_k), R(b_k)) over slots: a, b [..., J, 6] raw 6D, alpha [J] -> [...].
torch::Tensor weighted_geodesic(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& alpha);
// Eq. 25 for 6D: sum_k ||A_k^T A_k - I_2||_F^2 with A_k = the two 3-vectors of slot k. [..., J, 6] -> [...].
torch::Tensor rot6d_validity(const torch::Tensor& r6);
// KL(N(mq, sq^2) || N(mp, sp^2)) of diagonal Gaussians (spreads, not variances), summed over the last dim.
torch::Tensor gaussian_kl(const torch::Tensor& mq, const torch::Tensor& sq, const torch::Tensor& mp,
                          const torch::Tensor& sp);

}  // namespace hvrnn

// n x [Linear + ELU] then Linear with an optional final activation.
class HvrnnMlpImpl : public torch::nn::Module {
 public:
  enum class Out { kNone, kElu, kSoftplus };
  HvrnnMlpImpl(int in, int hidden, int layers, int out, Out last);
  torch::Tensor forward(torch::Tensor x);
  torch::nn::ModuleList layers;
  Out last;
};
TORCH_MODULE(HvrnnMlp);

class HvrnnImpl : public MotionModel {
 public:
  HvrnnImpl(const HvrnnOptions& options, const ModelContext& context);

  std::string family() const override { return "hvrnn"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const HvrnnOptions& options() const { return options_; }
  const HvrnnGeometry& geometry() const { return geometry_; }

  // Schedules: lambda_KL (warm-up, anneal, cool-down), lambda_CL (linear ramp), word drop rate.
  void set_progress(int step, int total_steps) override;
  double current_kl_weight() const;
  double current_classifier_weight() const;
  double current_word_drop() const;

  // Terms per valid frame: "recon" (hierarchical geodesic + root squared error, or squared error
  // without geometry), "kl", "validity", "classifier", "geodesic" (mean angle, rad), weights; "loss";
  // the foot objectives' terms when on (FootObjectiveOptions: planted_heel_mps, ...).
  LossTerms loss(const Batch& batch) override;
  // Clips shorter than the window train too (the paper's sequences of up to 200 frames from clip
  // starts), at least one word long; padding is masked out of every term.
  int short_window_min_frames() const override { return options_.word_length; }
  SampleOutput sample(const SampleRequest& request) override;
  ModelTraits traits() const override;
  // Frame by frame, equal to sample() for the same request: a new word is generated whenever
  // the last one's l frames are used up (the control argument is ignored: the model makes its own).
  std::unique_ptr<StreamState> begin_stream(const SampleRequest& request) override;
  StreamFrame step_stream(StreamState& state, const torch::Tensor& control) override;

  // One pass of the motion cell over N words. words [B, K, W] (K teacher-forced words, may be
  // undefined for K = 0); drop [B, K] bool (a dropped word feeds the cell's own output to the
  // state); h0 [B, S]; a [B, Da]. Draws noise from gen (nullptr = default generator).
  struct Unroll {
    torch::Tensor out;    // [B, N, W] reconstructed / generated words
    torch::Tensor kl;     // [B, K] KL(q || p) of the teacher-forced words (undefined if K = 0)
    torch::Tensor prior;  // [B, K, W] the teacher-forced words decoded from a prior draw (with_prior)
  };
  Unroll unroll(const torch::Tensor& words, const torch::Tensor& drop, int64_t n, const torch::Tensor& h0,
                const torch::Tensor& a, double temperature, at::Generator* gen, bool with_prior = false);
  // The terms on words decoded from prior draws at the teacher-forced states (u.prior): the
  // boundary term (boundary_weight) and the shared draw terms (draw, draw_chained), added to
  // *total; logs "boundary" and the draw terms in *terms. frames [B, N l, F] the padded window,
  // previous its teacher_previous, mask [B, N l] and word_mask [B, N] its valid frames and words.
  void prior_draw_terms(const Unroll& u, const torch::Tensor& frames, const torch::Tensor& previous,
                        const torch::Tensor& mask, const torch::Tensor& word_mask, const Batch& batch,
                        torch::Tensor* total, LossTerms* terms);

  // One motion-cell step on the state hs (updated): word [B, W] observed (Alg. 1; *kl receives
  // KL(q || p) [B] when kl is given) or undefined (Alg. 2, the prior). drop [B] bool (optional):
  // rows whose state update takes the cell's own output instead of the word. *prior_word (when
  // given with a word) receives the word decoded from a prior draw instead [B, W]; it does not
  // enter the state. Returns w~ [B, W].
  torch::Tensor cell_step(std::vector<torch::Tensor>& hs, const torch::Tensor& word, const torch::Tensor& drop,
                          const torch::Tensor& a, double temperature, at::Generator* gen, torch::Tensor* kl,
                          torch::Tensor* prior_word = nullptr);
  // The request's prefix as the whole words ending at its last frame [B, K, W] (undefined: none).
  torch::Tensor prefix_words(const SampleRequest& request, int64_t b);
  // frames [B, N l, F] -> words [B, N, W].
  torch::Tensor encode_words(const torch::Tensor& frames);
  // words [B, N, W] -> frames [B, N l, F]. previous [B, N, F + 1]: each word's previous frame and a
  // 1, or zeros where it has none (used with decoder_previous_frame, ignored otherwise).
  torch::Tensor decode_words(const torch::Tensor& words, const torch::Tensor& previous = {});
  // The teacher-forced previous frames of decode_words: frames [B, N l, F] -> [B, N, F + 1], word n
  // > 0 getting [frame n l - 1, 1], word 0 zeros.
  torch::Tensor teacher_previous(const torch::Tensor& frames) const;
  // Generated words [B, N, W] -> frames [B, N l, F] with rotations re-normalised, word by word
  // when the decoder sees the previous frame: *previous [B, F + 1] comes in as the first word's
  // (the prefix's last frame and a 1, or zeros) and leaves as the next word's (unused otherwise).
  // With `before` (generation) and boundary_blend, each word is blended onto the two frames before
  // it: *before [B, F] the frame before *previous's (undefined: none yet), updated likewise.
  torch::Tensor decode_generated(const torch::Tensor& words, torch::Tensor* previous, torch::Tensor* before = nullptr);
  // Generated frames of one word [B, l, F] joined to the frames before it (boundary_blend).
  torch::Tensor blend_boundary(const torch::Tensor& frames, const torch::Tensor& previous, const torch::Tensor& before) const;
  // The request's prefix as standardised frames [B, P, F] (control zeros when not given), checked;
  // undefined without a prefix.
  torch::Tensor prefix_frames(const SampleRequest& request, int64_t b);
  // The frames generation continues from: [B, F + 1] the request prefix's last standardised frame
  // (pose, control or zeros) and a 1, or zeros without a prefix; and [B, F] the frame before it
  // (decode_generated's `before`), undefined with fewer than two.
  std::pair<torch::Tensor, torch::Tensor> prefix_tail(const SampleRequest& request, int64_t b);
  // Label features a [B, Da] and the initial state h_0 [B, S] (mean + temperature spread noise).
  torch::Tensor label_code(const torch::Tensor& content, const torch::Tensor& style, int64_t b,
                           const torch::TensorOptions& opts);
  torch::Tensor initial_state(const torch::Tensor& content, const torch::Tensor& style, int64_t b,
                              double temperature, at::Generator* gen);
  // Standardised frames [.., F] with the rotation slots re-normalised by Gram-Schmidt.
  torch::Tensor normalise_rotations(const torch::Tensor& frames) const;
  int frame_dim() const { return context_.pose_dim + context_.control_dim; }
  int word_dim() const;

  HvrnnMlp word_encoder{nullptr}, word_decoder{nullptr};
  HvrnnMlp f_w{nullptr}, f_z{nullptr}, f_dec{nullptr};
  HvrnnMlp post_mu{nullptr}, post_sigma{nullptr}, prior_mu{nullptr}, prior_sigma{nullptr};
  torch::nn::Linear f_c{nullptr};
  torch::nn::ModuleList grus;
  torch::Tensor init_mean, init_logstd;  // [(num_content + 1) (num_style + 1), S]

 private:
  struct Recon {
    torch::Tensor recon, validity, geodesic;  // [B, T'] per frame
  };
  Recon reconstruction(const torch::Tensor& pred, const torch::Tensor& target);
  torch::Tensor classifier_term(const torch::Tensor& pred, const torch::Tensor& target, const Batch& batch);
  torch::Tensor draw(at::IntArrayRef sizes, const torch::TensorOptions& opts, at::Generator* gen) const;

  HvrnnOptions options_;
  ModelContext context_;
  HvrnnGeometry geometry_;
  int label_dim_ = 0;
  double progress_ = 1.0;  // fraction of training done (1 outside training)
  std::shared_ptr<ClassifierImpl> classifier_;  // frozen, loaded lazily; not a submodule
  FootObjectives foot_;                          // the shared foot terms (options_.foot)
  DrawObjectives draw_;                          // the shared terms on prior draws (options_.draw)
};
TORCH_MODULE(Hvrnn);

}  // namespace mosyn::nn
