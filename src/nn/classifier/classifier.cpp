#include "nn/classifier/classifier.h"

#include <torch/nn/functional/activation.h>
#include <torch/nn/functional/dropout.h>
#include <torch/nn/functional/loss.h>
#include <torch/utils.h>

#include <map>

#include "core/error.h"
#include "nn/options_fields.h"
#include "nn/standardiser.h"

namespace mosyn::nn {

namespace {

// Cross-entropy and accuracy over the rows whose label is >= 0; (0, 0, 0 rows) when none.
struct Ce {
  torch::Tensor ce, acc;
  int64_t rows = 0;
};
Ce labelled_ce(const torch::Tensor& logits, const torch::Tensor& labels) {
  Ce out;
  if (!labels.defined()) {
    out.ce = logits.sum() * 0.0;
    out.acc = torch::zeros({});
    return out;
  }
  const auto mask = labels.to(logits.device()) >= 0;
  out.rows = mask.sum().item<int64_t>();
  if (out.rows == 0) {
    out.ce = logits.sum() * 0.0;  // keeps the graph (and the gradient: zeros)
    out.acc = torch::zeros({});
    return out;
  }
  const auto l = logits.index({mask});
  const auto y = labels.to(logits.device()).index({mask});
  out.ce = torch::nn::functional::cross_entropy(l, y);
  out.acc = (l.argmax(1) == y).to(torch::kFloat32).mean().detach();
  return out;
}

const OptionFields<ClassifierOptions>& classifier_fields() {
  using O = ClassifierOptions;
  static const auto fields =
      OptionFields<O>("classifier")
          .field("channels", &O::channels, "channels of every convolution", at_least(1))
          .field("kernel", &O::kernel, "temporal kernel width", odd_at_least(1))
          .field("features", &O::features, "size of the penultimate (feature) layer", at_least(1))
          .field("dropout", &O::dropout, "dropout on the features in training", in_range(0.0, 1.0, false))
          .field("use_control", &O::use_control, "also feed the control besides the pose")
          .field("style_weight", &O::style_weight, "weight of the style cross-entropy", at_least(0.0));
  return fields;
}

}  // namespace

ClassifierOptions ClassifierOptions::from_json(const nlohmann::json& config) {
  ClassifierOptions o;
  classifier_fields().read(config, &o);
  classifier_fields().check(o);
  return o;
}

nlohmann::json ClassifierOptions::to_json() const { return classifier_fields().write(*this); }

ClassifierImpl::ClassifierImpl(const ClassifierOptions& options, const ModelContext& context)
    : TrainableModel("Classifier"), options_(options), context_(context) {
  if (context.num_content < 1)
    throw Error("the classifier needs content labels, but the dataset has none (prepare it from a labelled source)");
  const int in = context.pose_dim + (options.use_control ? context.control_dim : 0);
  const int h = options.channels, k = options.kernel, pad = k / 2;
  conv1 = register_module("conv1", torch::nn::Conv1d(torch::nn::Conv1dOptions(in, h, k).padding(pad)));
  conv2 = register_module("conv2", torch::nn::Conv1d(torch::nn::Conv1dOptions(h, h, k).padding(pad).stride(2)));
  conv3 = register_module("conv3", torch::nn::Conv1d(torch::nn::Conv1dOptions(h, h, k).padding(pad)));
  feature = register_module("feature", torch::nn::Linear(h, options.features));
  content_head = register_module("content_head", torch::nn::Linear(options.features, context.num_content));
  if (context.num_style > 0)
    style_head = register_module("style_head", torch::nn::Linear(options.features, context.num_style));
}

ClassifierImpl::Output ClassifierImpl::forward(const torch::Tensor& pose, const torch::Tensor& control) {
  if (pose.dim() != 3 || pose.size(2) != context_.pose_dim)
    throw Error("classifier: pose must be [B, T, " + std::to_string(context_.pose_dim) + "]");
  torch::Tensor x = pose;
  if (options_.use_control) {
    torch::Tensor c = control.defined() ? control
                                        : torch::zeros({pose.size(0), pose.size(1), context_.control_dim}, pose.options());
    if (c.dim() != 3 || c.size(0) != pose.size(0) || c.size(1) != pose.size(1) || c.size(2) != context_.control_dim)
      throw Error("classifier: control must be [B, T, " + std::to_string(context_.control_dim) + "] like the pose");
    x = torch::cat({pose, c.to(pose.options())}, 2);
  }
  x = x.transpose(1, 2);  // [B, channels, T]
  x = torch::relu(conv1->forward(x));
  x = torch::relu(conv2->forward(x));
  x = torch::relu(conv3->forward(x));
  x = x.mean(2);  // adaptive average pooling to one step: [B, H]
  Output out;
  out.features = torch::relu(feature->forward(x));
  const auto f = torch::nn::functional::dropout(
      out.features, torch::nn::functional::DropoutFuncOptions().p(options_.dropout).training(is_training()));
  out.content_logits = content_head->forward(f);
  if (style_head) out.style_logits = style_head->forward(f);
  return out;
}

LossTerms ClassifierImpl::loss(const Batch& batch) {
  const Output out = forward(batch.pose, batch.control);
  LossTerms t;
  const Ce content = labelled_ce(out.content_logits, batch.content);
  torch::Tensor total = content.ce;
  t.terms["content_ce"] = content.ce.detach();
  t.terms["content_acc"] = content.acc;
  if (style_head) {
    const Ce style = labelled_ce(out.style_logits, batch.style);
    total = total + options_.style_weight * style.ce;
    t.terms["style_ce"] = style.ce.detach();
    t.terms["style_acc"] = style.acc;
  }
  t.terms["loss"] = total;
  return t;
}


ClassifierOutputs classify_windows(const LoadedRun& run, const std::vector<std::vector<float>>& poses,
                                   const std::vector<std::vector<float>>& controls) {
  auto* model = dynamic_cast<ClassifierImpl*>(run.trainable.get());
  if (!model) throw Error(run.run_dir + ": not a classifier run (family '" + run.family + "')");
  if (!controls.empty() && controls.size() != poses.size())
    throw Error("classify_windows: " + std::to_string(controls.size()) + " controls for " +
                std::to_string(poses.size()) + " poses");
  const int64_t d = run.context.pose_dim, c = run.context.control_dim;
  ClassifierOutputs out;
  out.num_windows = static_cast<int>(poses.size());
  out.num_features = model->options().features;
  out.num_content = model->num_content();
  out.num_style = model->num_style();
  out.features.assign(poses.size() * out.num_features, 0.f);
  out.content_probabilities.assign(poses.size() * out.num_content, 0.f);
  out.style_probabilities.assign(poses.size() * out.num_style, 0.f);
  auto params = model->parameters();
  const torch::Device device = params.empty() ? torch::Device(torch::kCPU) : params.front().device();
  const Standardiser standardiser(run.stats);
  if (standardiser.pose_dim() != d || standardiser.control_dim() != c)
    throw Error(run.run_dir + ": stats do not match the model");

  // Group windows by length, so each batch is one tensor.
  std::map<int64_t, std::vector<size_t>> by_length;
  for (size_t i = 0; i < poses.size(); ++i) {
    if (poses[i].empty() || poses[i].size() % d != 0)
      throw Error("classify_windows: window " + std::to_string(i) + " is not [T, " + std::to_string(d) + "]");
    const int64_t t = static_cast<int64_t>(poses[i].size()) / d;
    if (!controls.empty() && !controls[i].empty() && controls[i].size() != static_cast<size_t>(t * c))
      throw Error("classify_windows: control of window " + std::to_string(i) + " is not [" + std::to_string(t) +
                  ", " + std::to_string(c) + "]");
    by_length[t].push_back(i);
  }
  torch::NoGradGuard no_grad;
  model->eval();
  constexpr size_t kBatch = 256;
  for (const auto& kv : by_length) {
    const int64_t t = kv.first;
    const auto& idx = kv.second;
    for (size_t b = 0; b < idx.size(); b += kBatch) {
      const int64_t n = static_cast<int64_t>(std::min(kBatch, idx.size() - b));
      auto pose = torch::empty({n, t, d});
      auto ctrl = torch::zeros({n, t, c});
      for (int64_t k = 0; k < n; ++k) {
        const size_t i = idx[b + k];
        pose[k].copy_(torch::from_blob(const_cast<float*>(poses[i].data()), {t, d}, torch::kFloat32));
        if (!controls.empty() && !controls[i].empty())
          ctrl[k].copy_(
              standardiser.control(torch::from_blob(const_cast<float*>(controls[i].data()), {t, c}, torch::kFloat32)));
      }
      pose = standardiser.pose(pose);
      const ClassifierImpl::Output o = model->forward(pose.to(device), ctrl.to(device));
      const auto f = o.features.to(torch::kCPU, torch::kFloat32).contiguous();
      const auto pc = torch::softmax(o.content_logits, 1).to(torch::kCPU, torch::kFloat32).contiguous();
      torch::Tensor ps;
      if (o.style_logits.defined()) ps = torch::softmax(o.style_logits, 1).to(torch::kCPU, torch::kFloat32).contiguous();
      for (int64_t k = 0; k < n; ++k) {
        const size_t i = idx[b + k];
        std::copy_n(f[k].data_ptr<float>(), out.num_features, out.features.begin() + i * out.num_features);
        std::copy_n(pc[k].data_ptr<float>(), out.num_content, out.content_probabilities.begin() + i * out.num_content);
        if (ps.defined())
          std::copy_n(ps[k].data_ptr<float>(), out.num_style, out.style_probabilities.begin() + i * out.num_style);
      }
    }
  }
  return out;
}

}  // namespace mosyn::nn

// Inside the macro, names resolve in mosyn::nn.
MOSYN_REGISTER_FAMILY(classifier,
                      FamilyInfo{"classifier", FamilyKind::kClassifier,
                                 "content / style classifier for recognisability metrics (Ghorbani et al. 2020)",
                                 [](const nlohmann::json& config, const ModelContext& context) {
                                   return std::make_shared<ClassifierImpl>(ClassifierOptions::from_json(config),
                                                                           context);
                                 },
                                 {{"channels", 8}, {"kernel", 3}, {"features", 8}},
                                 {}})
