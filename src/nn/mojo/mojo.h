// MOJO: "We are More than Our Joints: Predicting how 3D Bodies Move", Zhang, Black & Tang (CVPR
// 2021), /work/shared/papers/zhang2021-mojo.txt. Family name "mojo". See src/nn/mojo/README.md for
// what is kept, what is lost (no SMPL-X / VPoser / AMASS) and the choices where the paper is silent.
//
// Per frame the model sees x_t = [pose_t, control_t] (D + C, standardised): with the marker pose
// form the 41 CMU markers in the frame's heading frame plus the root's motion, which the model
// generates (traits: control kGenerates). A training window of T frames is split into P observed
// frames (observed, at most T - 1) and F = min(future, T - P) future frames.
//
//   past encoder:    GRU over x_{1..P}                          -> h_x [B, H] (last state)
//   future encoder:  GRU over y_{1..F}                          -> h_y [B, F, H] (every state)
//   latent DCT:      bands = C_F h_y (orthonormal DCT-II over time, dct.h) [B, F, H]
//                    per band: MLP([band_k, h_x]) -> mean_k, logvar_k [B, F, Z] (Z = 16)
//                    z = mean + exp(logvar / 2) eps;  the decoder's latent sequence = C_F^T z [B, F, Z]
//   "-DCT" variant:  h_y = the future GRU's last state; one latent z [B, Z] (Z = 128), the same at
//                    every step
//   decoder:         GRU cell over t = 1..F on [h_x, zseq_t, y_{t-1}] -> MLP -> delta;
//                    y_t = y_{t-1} + delta (residual output), y_0 = x_P
//   loss (stage "cvae"), per sequence: sum (y - y^)^2 + velocity_weight sum (dy - dy^)^2
//                    + kl_weight * KLterm, KLterm = sqrt(1 + KL^2) - 1 (robust, Charbonnier) with
//                    latent DCT, KL itself for "-DCT"; KL summed over bands and dimensions.
//   DLow (stage "dlow", everything above frozen): for each of the dlow_bands lowest bands its own
//                    network Q_b (a shared GRU over x_{1..P}, then per band an MLP) maps the
//                    past to K affine maps; one noise eps_b ~ N(0, I) per band and past gives
//                    K latents z_{k,b} = A_{k,b} * eps_b + b_{k,b}; higher bands from N(0, I).
//                    Loss: kl (each z_{k,b} distribution against N(0, I)), best-of-K reconstruction,
//                    diversity exp(-rms distance / div_scale) over pairs (Yuan & Kitani 2020).
//   sampling:        per group of K consecutive rows one eps per band (rows = the K samples of one
//                    past); the DLow latents once stage "dlow" has run (prior latents before);
//                    futures longer than F are made F frames at a time from the last P frames.
//   projection:      with the marker form and a skeleton in the context, every predicted frame's
//                    markers are replaced by those of the skeleton fitted to them (projection.h).
// All tensors standardised (nn/model.h conventions).
#pragma once

#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>

#include <memory>
#include <string>
#include <vector>

#include "nn/model.h"
#include "nn/objectives/draw_objectives.h"
#include "nn/objectives/foot_objectives.h"
#include "nn/mojo/projection.h"

namespace mosyn::nn {

struct MojoOptions {
  std::string preset = "mojo";  // "mojo" (latent DCT, robust KL) or "mojo-dct" (one latent, plain KL)
  bool latent_dct = true;       // latent frequency bands (false = the "-DCT" variant)
  int latent = 16;              // Z per band (the paper: 16 with DCT, 128 without)
  int observed = 15;            // P: observed frames (1 s at 15 fps)
  int future = 45;              // F: predicted frames per pass (3 s at 15 fps)
  int hidden = 128;             // GRU width (DLow's CVAE: 128)
  std::vector<int> mlp = {300, 200};  // hidden widths of the posterior and decoder MLPs (DLow's)
  double velocity_weight = 3.0;       // alpha of the velocity term (value lost from the paper's text)
  std::string kl = "robust";          // "robust" (Charbonnier of the KL) or "standard"
  double kl_weight = 1.0;             // 1 robust (paper), 0.1 standard (paper, "-DCT")
  // DLow (second stage)
  int dlow_bands = 9;            // lowest bands mapped by DLow (the paper: 20 % = 9 of 45)
  int dlow_k = 50;               // K samples per past
  int dlow_hidden = 128;         // Q's GRU and MLP width
  double dlow_kl_weight = 1.0;
  double dlow_recon_weight = 2.0;
  double dlow_div_weight = 2.0;
  double dlow_div_scale = 1.0;   // standardised units of RMS distance in exp(-d / scale)
  double dlow_fraction = 0.25;   // share of the run's steps for the DLow stage
  int dlow_batch = 0;            // DLow stage: pasts per step taken from the batch (0 = all); each
                                 // costs K decoder passes, so a CPU run may take fewer
  // Sampling
  std::string sampler = "dlow";  // "dlow" (when its stage has run) or "prior" (N(0, I) in every band)
  bool projection = true;        // recursive projection (marker form with a skeleton only)
  int projection_iterations = 10;
  double projection_prior = 1e-4;
  int projection_threads = 0;    // 0 = hardware concurrency
  // The shared foot objectives (not in the paper; nn/objectives/foot_objectives.h: heels LHEE /
  // RHEE, toes LTOE / RTOE, pelvis the waist markers) in stage "cvae", on each window's predicted
  // future after its last observed frame, the markers moving with the root steps the model predicts:
  // drawn free, the paper's loss left the feet skating 5-6x real walks. Keys at the top level of
  // the config; every weight 0 = off (the paper). DLow's stage leaves them out (the CVAE is frozen).
  FootObjectiveOptions foot;
  // The shared terms on free draws (nn/objectives/draw_objectives.h; not in the paper), stage
  // "cvae": each window's future decoded a second time from a prior latent (as at sampling with
  // sampler "prior"; DLow's latents are trained to stay near that prior), against the window's
  // real future: phase-free stance, speed distribution, toe slide, and the root speed. The foot
  // terms on the reconstruction alone left draws skating 3.5x real walks (docs/experiments.md).
  DrawObjectiveOptions draw;

  static MojoOptions from_json(const nlohmann::json& config);
  nlohmann::json to_json() const;
};

class MojoImpl : public MotionModel {
 public:
  MojoImpl(const MojoOptions& options, const ModelContext& context);

  std::string family() const override { return "mojo"; }
  nlohmann::json config() const override { return options_.to_json(); }
  const MojoOptions& options() const { return options_; }
  ModelTraits traits() const override;

  std::vector<TrainingStage> training_stages(const TrainStageDefaults& defaults) const override;
  void begin_stage(int index, const TrainingStage& stage) override;
  // Stage "cvae": terms "loss" (per feature and future frame), "recon", "velocity", "kl" (nats per
  // sequence), "kl_term", and the foot objectives' terms when on (MojoOptions::foot). Stage "dlow": "loss", "dlow_recon", "dlow_kl", "dlow_div".
  LossTerms loss(const Batch& batch) override;
  SampleOutput sample(const SampleRequest& request) override;

  int frame_dim() const { return frame_dim_; }
  // Past [B, P, D + C] -> h_x [B, H].
  torch::Tensor encode_past(const torch::Tensor& past);
  // Future [B, F, D + C] and h_x -> posterior mean, logvar: [B, F, Z] (latent DCT) or [B, 1, Z].
  std::pair<torch::Tensor, torch::Tensor> encode_future(const torch::Tensor& future, const torch::Tensor& h_x);
  // The decoder's per-step latent [B, F, Z] from latents [B, F, Z] (bands: inverse DCT) or [B, 1, Z].
  torch::Tensor latent_sequence(const torch::Tensor& z, int64_t frames) const;
  // Decodes F frames from h_x [B, H], the latent sequence [B, F, Z] and the last observed frame
  // [B, D + C]; with a projector, every frame is projected before it is fed back.
  torch::Tensor decode(const torch::Tensor& h_x, const torch::Tensor& zseq, const torch::Tensor& last,
                       mojo::MarkerProjector* projector = nullptr);
  // DLow: past [B, P, D + C], eps [B, nb, Z] -> latents of the nb lowest bands for K samples
  // [B, K, nb, Z], and the maps' means and log-variances (same shape) for the KL.
  struct DlowOut {
    torch::Tensor z, mean, logvar;
  };
  DlowOut dlow_latents(const torch::Tensor& past, const torch::Tensor& eps);
  int dlow_band_count(int64_t frames) const;
  bool dlow_trained() const { return dlow_trained_.item<float>() > 0.5f; }
  // Timing of the last sample()'s projections of predicted frames (zeros without projection).
  mojo::ProjectionTiming last_projection_timing() const { return last_timing_; }
  std::vector<SampleStageTiming> last_sample_timings() const override;

  torch::nn::GRU past_rnn{nullptr}, future_rnn{nullptr};
  torch::nn::Sequential posterior{nullptr};
  torch::nn::GRUCell dec_cell{nullptr};
  torch::nn::Sequential dec_mlp{nullptr};
  torch::nn::GRU dlow_rnn{nullptr};
  torch::nn::ModuleList dlow_heads{nullptr};

 private:
  // batch: the window's labels, for the foot objectives' label weights.
  LossTerms cvae_loss(const torch::Tensor& past, const torch::Tensor& future, const Batch& batch);
  LossTerms dlow_loss(const torch::Tensor& past, const torch::Tensor& future);
  bool can_project() const;
  MojoOptions options_;
  ModelContext context_;
  int frame_dim_ = 0;
  int stage_ = 0;
  torch::Tensor dlow_trained_;  // buffer: 1 once the DLow stage has begun
  mojo::ProjectionTiming last_timing_;
  FootObjectives foot_;  // the shared foot terms (options_.foot)
  DrawObjectives draw_;  // the shared terms on prior draws (options_.draw)
};
TORCH_MODULE(Mojo);

}  // namespace mosyn::nn
