// hvrnn options, geometry (rotation slots, Eq. 23 weights) and the loss pieces (Eq. 21/22, 25, KL).
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "nn/gaussian.h"
#include "nn/hvrnn/hvrnn.h"
#include "nn/kinematics.h"
#include "nn/options_fields.h"

namespace mosyn::nn {

// ---------------------------------------------------------------------------------------------
// Options

namespace {

const OptionFields<HvrnnOptions>& hvrnn_fields() {
  using O = HvrnnOptions;
  static const auto fields =
      OptionFields<O>("hvrnn")
          .field("preset", &O::preset, "named defaults: full, SL (no word coder), NL (alpha 1), NC (no classifier)",
                 one_of({"full", "SL", "NL", "NC"}))
          .field("word_length", &O::word_length, "l, frames per motion word", at_least(1))
          .field("word_coder", &O::word_coder, "motion-word encoder / decoder (false = SL ablation)")
          .field("word_hidden", &O::word_hidden, "width of the word coder's hidden layers", at_least(1))
          .field("word_code", &O::word_code, "D_w, motion-word size", at_least(1))
          .field("feature_hidden", &O::feature_hidden, "width of f_w, f_z, f_dec hidden layers", at_least(1))
          .field("feature", &O::feature, "output size of f_w and f_z", at_least(1))
          .field("latent", &O::latent, "D_z, latent size", at_least(1))
          .field("gaussian_hidden", &O::gaussian_hidden, "width of the posterior / prior MLPs", at_least(1))
          .field("gaussian_layers", &O::gaussian_layers, "hidden layers of the posterior / prior MLPs", at_least(1))
          .field("state", &O::state, "units per GRU cell", at_least(1))
          .field("state_layers", &O::state_layers, "stacked GRU cells", at_least(1))
          .field("label_code", &O::label_code, "D_a, size of the label features", at_least(1))
          .field("label_dropout", &O::label_dropout, "probability a window's label is dropped in training",
                 in_range(0.0, 1.0))
          .field("init_std", &O::init_std, "initial spread of the initial-state Gaussians", at_least(1e-6))
          .field("alpha", &O::alpha, "joint weights of the geodesic loss", one_of({"hierarchical", "uniform"}))
          .field("alpha_floor", &O::alpha_floor, "least alpha as a fraction of the largest", in_range(0.0, 1.0))
          .field("root_weight", &O::root_weight, "weight of the non-rotation channels' squared error", at_least(0.0))
          .field("kl_weight", &O::kl_weight, "lambda_KL after annealing", at_least(0.0))
          .field("kl_warmup", &O::kl_warmup, "fraction of training with lambda_KL = 0", in_range(0.0, 1.0))
          .field("kl_anneal", &O::kl_anneal, "fraction over which lambda_KL ramps up", in_range(0.0, 1.0))
          .field("kl_free_nats", &O::kl_free_nats, "free nats per valid frame under which the KL is not pushed down",
                 at_least(0.0))
          .field("velocity_weight", &O::velocity_weight, "weight of the frame-to-frame velocity error",
                 at_least(0.0))
          .field("decoder_previous_frame", &O::decoder_previous_frame,
                 "the word decoder also sees the frame before its word")
          .field("boundary_weight", &O::boundary_weight,
                 "weight of the first-frame error of words decoded from a prior draw", at_least(0.0))
          .field("validity_weight", &O::validity_weight, "lambda_Ang, 6D validity penalty", at_least(0.0))
          .field("classifier_run", &O::classifier_run, "trained classifier run for the classifier loss (\"\" = off)")
          .field("classifier_weight", &O::classifier_weight, "lambda_CL after its ramp", at_least(0.0))
          .field("classifier_ramp", &O::classifier_ramp, "fraction over which lambda_CL grows", in_range(0.0, 1.0))
          .field("classifier_feature_weight", &O::classifier_feature_weight, "beta of the feature l2 term",
                 at_least(0.0))
          .field("word_drop", &O::word_drop, "final probability a teacher-forced word is dropped",
                 in_range(0.0, 1.0))
          .field("word_drop_ramp", &O::word_drop_ramp, "fraction over which the drop rate grows",
                 in_range(0.0, 1.0))
          .field("spread_floor", &O::spread_floor, "added to every softplus spread", at_least(0.0))
          .include(&O::foot, foot_objective_fields())
          .include(&O::draw, draw_objective_fields())
          .field("draw_chained", &O::draw_chained,
                 "training: the draw terms' words decoded one after another, as generation does")
          .written_if([](const O& o) { return o.draw_chained; })
          .field("boundary_blend", &O::boundary_blend,
                 "generation: decay a frame of the offset joining each word to the frames before it (0 = off)",
                 in_range(0.0, 1.0, false))
          .written_if([](const O& o) { return o.boundary_blend > 0; })
          .rule([](const O& o) -> std::string {
            return o.draw_chained && !o.decoder_previous_frame ? "draw_chained needs decoder_previous_frame" : "";
          })
          .rule([](const O& o) {
            return o.decoder_previous_frame && !o.word_coder ? "decoder_previous_frame needs the word coder" : "";
          })
          .rule([](const O& o) {
            return o.kl_warmup + o.kl_anneal > 1.0 + 1e-9 ? "kl_warmup + kl_anneal must be at most 1" : "";
          });
  return fields;
}

}  // namespace

HvrnnOptions HvrnnOptions::from_json(const nlohmann::json& config) {
  const auto& fields = hvrnn_fields();
  HvrnnOptions o;
  if (!config.is_object()) throw Error("hvrnn config must be a JSON object");
  if (config.contains("preset")) fields.read_key(config, "preset", &o);  // the preset's defaults first
  if (o.preset == "SL") {
    o.word_coder = false;
    o.word_length = 1;
  } else if (o.preset == "NL") {
    o.alpha = "uniform";
  } else if (o.preset == "NC") {
    o.classifier_weight = 0.0;
  }
  fields.read(config, &o);
  fields.check(o);
  return o;
}

nlohmann::json HvrnnOptions::to_json() const { return hvrnn_fields().write(*this); }

// ---------------------------------------------------------------------------------------------
// Geometry

namespace hvrnn {

std::vector<double> hierarchical_alphas(const std::vector<int>& parents, const std::vector<double>& bone_lengths,
                                        double floor_fraction) {
  const size_t j_count = parents.size();
  if (bone_lengths.size() != j_count) throw Error("hvrnn: one bone length per joint");
  std::vector<double> alpha(j_count, 0.0);
  for (size_t j = j_count; j-- > 0;) {  // children come after their parents
    const int p = parents[j];
    if (p < 0) continue;
    if (p >= static_cast<int>(j)) throw Error("hvrnn: parents must precede their children");
    alpha[p] = std::max(alpha[p], alpha[j] + bone_lengths[j]);
  }
  const double top = j_count ? *std::max_element(alpha.begin(), alpha.end()) : 0.0;
  if (top <= 0) return std::vector<double>(j_count, 1.0);
  double sum = 0;
  for (double& a : alpha) sum += (a = std::max(a, floor_fraction * top));
  for (double& a : alpha) a *= static_cast<double>(j_count) / sum;
  return alpha;
}

HvrnnGeometry geometry_for(const ModelContext& c, const HvrnnOptions& options) {
  HvrnnGeometry g;
  const auto& sk = c.skeleton;
  const int j_count = sk.num_joints();
  if (c.pose_form != data::PoseForm::kRotations || j_count == 0 || c.layout.pose_dim != c.pose_dim ||
      static_cast<int>(c.stats.pose_mean.size()) != c.pose_dim ||
      static_cast<int>(c.stats.pose_std.size()) != c.pose_dim)
    return g;
  const bool smoothed = c.layout.smoothed_root();
  if (data::expected_pose_dim(data::PoseForm::kRotations, j_count, smoothed) != c.pose_dim) return g;
  const int r = c.layout.root_joint;
  g.slot_joint.push_back(r);
  for (int j = 0; j < j_count; ++j)
    if (j != r) g.slot_joint.push_back(j);
  g.num_joints = j_count;
  g.other_dims.push_back(0);
  if (smoothed) g.other_dims.insert(g.other_dims.end(), {c.pose_dim - 2, c.pose_dim - 1});
  std::vector<double> per_joint(j_count, 1.0);
  if (options.alpha == "hierarchical") {
    std::vector<double> lengths(j_count);
    for (int j = 0; j < j_count; ++j) lengths[j] = sk.offsets[j].norm() * sk.meters_per_unit;
    per_joint = hierarchical_alphas(sk.parents, lengths, options.alpha_floor);
  }
  for (int k = 0; k < j_count; ++k) g.alpha.push_back(per_joint[g.slot_joint[k]]);
  g.mean = torch::tensor(c.stats.pose_mean, torch::kFloat32);
  g.std = torch::tensor(c.stats.pose_std, torch::kFloat32);
  g.valid = true;
  return g;
}

torch::Tensor weighted_geodesic(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& alpha) {
  auto angle = geodesic_angle(matrix_from_rot6d(a), matrix_from_rot6d(b));  // [..., J]
  return (angle * alpha.to(angle.options())).sum(-1);
}

torch::Tensor rot6d_validity(const torch::Tensor& r6) {
  auto c0 = r6.narrow(-1, 0, 3), c1 = r6.narrow(-1, 3, 3);
  auto n0 = (c0 * c0).sum(-1) - 1.0, n1 = (c1 * c1).sum(-1) - 1.0, d = (c0 * c1).sum(-1);
  return (n0 * n0 + n1 * n1 + 2.0 * d * d).sum(-1);  // ||A^T A - I||_F^2: off-diagonal counted twice
}

torch::Tensor gaussian_kl(const torch::Tensor& mq, const torch::Tensor& sq, const torch::Tensor& mp,
                          const torch::Tensor& sp) {
  return diagonal_gaussian_kl(mq, 2.0 * torch::log(sq), mp, 2.0 * torch::log(sp));
}

torch::Tensor velocity_error(const torch::Tensor& pred, const torch::Tensor& target, const torch::Tensor& mask) {
  const int64_t t = pred.size(1);
  if (t < 2) return torch::zeros({}, pred.options());
  auto step = [&](const torch::Tensor& x) { return x.narrow(1, 1, t - 1) - x.narrow(1, 0, t - 1); };
  // Valid frames form a prefix of each window, so a pair counts when its later frame is valid.
  auto pair_mask = mask.narrow(1, 1, t - 1);
  auto error = 0.5 * (step(pred) - step(target)).pow(2).sum(-1);
  return (error * pair_mask).sum() / pair_mask.sum().clamp_min(1.0);
}

}  // namespace hvrnn

// ---------------------------------------------------------------------------------------------
// Mlp

HvrnnMlpImpl::HvrnnMlpImpl(int in, int hidden, int n, int out, Out last_activation) : last(last_activation) {
  layers = register_module("layers", torch::nn::ModuleList());
  int width = in;
  for (int i = 0; i < n; ++i) {
    layers->push_back(torch::nn::Linear(width, hidden));
    width = hidden;
  }
  layers->push_back(torch::nn::Linear(width, out));
}

torch::Tensor HvrnnMlpImpl::forward(torch::Tensor x) {
  const size_t n = layers->size();
  for (size_t i = 0; i < n; ++i) {
    x = layers[i]->as<torch::nn::LinearImpl>()->forward(x);
    if (i + 1 < n) x = torch::elu(x);
  }
  switch (last) {
    case Out::kNone: return x;
    case Out::kElu: return torch::elu(x);
    case Out::kSoftplus: return torch::softplus(x);
  }
  return x;
}

}  // namespace mosyn::nn
