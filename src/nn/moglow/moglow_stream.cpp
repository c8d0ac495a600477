// MoGlow's batched inference stream (moglow_stream.h).
#include "nn/moglow/moglow_stream.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/utils.h>

#include <string>
#include <utility>

#include "core/error.h"
#include "nn/moglow/moglow.h"

namespace mosyn::nn {

namespace {

int64_t padded(int64_t n) { return (n + 63) / 64 * 64; }

// Doubles the g gate (rows 2H..3H-1) of LSTM weights [4H, ...] or biases [4H].
torch::Tensor double_g(torch::Tensor w, int64_t h) {
  w = w.clone();
  w.narrow(0, 2 * h, h).mul_(2.0);
  return w;
}

torch::Tensor param(torch::nn::Module& m, const std::string& name) {
  auto* p = m.named_parameters().find(name);
  if (!p) throw Error("moglow: LSTM parameter '" + name + "' missing");
  return p->detach();
}

// Step k's LSTM, output layer and reverse map into net (the first layer's conditioning columns
// into the k-th block of cond_blocks / bias_blocks).
void fuse_step(FlowStepImpl& step, MoGlowInference& net, std::vector<torch::Tensor>& cond_blocks,
               std::vector<torch::Tensor>& bias_blocks) {
  const int64_t h = net.hidden, d_lo = net.d_lo, d_hi = net.d_hi;
  auto& lstm = *step.coupling->lstm;
  for (int64_t l = 0; l < net.layers; ++l) {
    const std::string s = std::to_string(l);
    auto w_ih = double_g(param(lstm, "weight_ih_l" + s), h), w_hh = double_g(param(lstm, "weight_hh_l" + s), h);
    auto bias = double_g(param(lstm, "bias_ih_l" + s) + param(lstm, "bias_hh_l" + s), h);
    const int64_t in = l == 0 ? d_lo : h;
    net.w_rec.push_back(torch::cat({w_ih.narrow(1, 0, in), w_hh}, 1).t().contiguous());
    if (l == 0) {
      cond_blocks.push_back(w_ih.narrow(1, d_lo, w_ih.size(1) - d_lo).t());
      bias_blocks.push_back(bias);
      net.b_rec.emplace_back();
    } else {
      net.b_rec.push_back(bias.contiguous());
    }
  }
  auto& out = *step.coupling->out;
  auto w = out.weight.detach(), b = out.bias.detach();
  auto w_out = torch::zeros({h, net.scale_cols + d_hi}, w.options());
  auto b_out = torch::zeros({net.scale_cols + d_hi}, w.options());
  w_out.narrow(1, 0, d_hi).copy_(w.narrow(0, d_hi, d_hi).t());
  b_out.narrow(0, 0, d_hi).copy_(b.narrow(0, d_hi, d_hi) + 2.0);
  w_out.narrow(1, net.scale_cols, d_hi).copy_(w.narrow(0, 0, d_hi).t());
  b_out.narrow(0, net.scale_cols, d_hi).copy_(b.narrow(0, 0, d_hi));
  net.w_out.push_back(w_out);
  net.b_out.push_back(b_out);
  auto w_inverse = torch::inverse(step.linear->weight().detach());
  auto gain = torch::exp(-step.actnorm->logs.detach());
  net.w_rev.push_back((w_inverse.t() * gain.unsqueeze(0)).contiguous());
  net.b_rev.push_back((-step.actnorm->bias.detach()).contiguous());
}

}  // namespace

MoGlowInference MoGlowInference::of(MoGlowImpl& model) {
  torch::NoGradGuard no_grad;
  const auto& o = model.options();
  MoGlowInference net;
  net.steps = static_cast<int64_t>(model.steps.size());
  net.layers = o.lstm_layers;
  net.hidden = o.hidden;
  net.dim = model.context().pose_dim;
  net.d_lo = net.dim / 2;
  net.d_hi = net.dim - net.d_lo;
  net.gate_cols = padded(4 * net.hidden);
  net.cell_cols = padded(net.hidden);
  net.scale_cols = padded(net.d_hi);
  net.scale_eps = o.scale_eps;
  std::vector<torch::Tensor> cond_blocks, bias_blocks;
  for (auto& step : model.steps) fuse_step(*step, net, cond_blocks, bias_blocks);
  const auto device = model.steps.front()->actnorm->bias.device();
  net.w_cond = torch::cat(cond_blocks, 1).contiguous().to(device);
  net.b_cond = torch::cat(bias_blocks, 0).contiguous().to(device);
  for (auto* list : {&net.w_rec, &net.b_rec, &net.w_out, &net.b_out, &net.w_rev, &net.b_rev})
    for (auto& t : *list)
      if (t.defined()) t = t.to(device);
  return net;
}

MoGlowStream::MoGlowStream(MoGlowImpl& model, int64_t b, const std::vector<std::uint64_t>& seeds)
    : shared_net(model.inference()), net(*shared_net), batch(b) {
  if (static_cast<int64_t>(seeds.size()) != b) throw Error("moglow stream: one seed per row needed");
  tau = model.options().tau;
  if (model.transport()) transport = *model.transport();
  pose_dim = model.context().pose_dim;
  control_dim = model.context().control_dim;
  label_dim = model.label_dim();
  lookahead_dim = model.cond_dim() - tau * pose_dim - (tau + 1) * control_dim - label_dim;
  options = model.steps.front()->actnorm->bias.options().requires_grad(false);
  cond = torch::zeros({b, model.cond_dim()}, options);
  cond_next = torch::zeros_like(cond);
  const int64_t h = net.hidden;
  for (int64_t k = 0; k < net.steps; ++k)
    for (int64_t l = 0; l < net.layers; ++l) {
      input_h.push_back(torch::zeros({b, (l == 0 ? net.d_lo : h) + h}, options));
      cell.push_back(torch::zeros({b, net.cell_cols}, options));
    }
  for (auto seed : seeds) generators.push_back(at::detail::createCPUGenerator(seed));
  gates_cond = torch::zeros({b, net.steps * 4 * h}, options);
  gates = torch::zeros({b, net.gate_cols}, options);
  tanh_c = torch::zeros({b, net.cell_cols}, options);
  out = torch::zeros({b, net.scale_cols + net.d_hi}, options);
  x = torch::zeros({b, pose_dim}, options);
  x_next = torch::zeros_like(x);
  noise = torch::zeros({b, pose_dim}, options.device(torch::kCPU));
}

void MoGlowStream::set_history(const torch::Tensor& pose_hist, const torch::Tensor& ctrl_hist,
                               const torch::Tensor& labels) {
  torch::NoGradGuard no_grad;
  const int64_t d = pose_dim, c = control_dim;
  for (auto* t : {&cond, &cond_next}) {
    t->narrow(1, 0, tau * d).copy_(pose_hist.reshape({batch, tau * d}));
    t->narrow(1, tau * d, tau * c).copy_(ctrl_hist.reshape({batch, tau * c}));
    if (label_dim > 0) {
      auto part = t->narrow(1, tau * d + (tau + 1) * c, label_dim);
      labels.defined() ? part.copy_(labels) : part.zero_();
    }
  }
}

void MoGlowStream::set_lstm_states(const std::vector<c10::optional<LstmState>>& states) {
  torch::NoGradGuard no_grad;
  const int64_t h = net.hidden;
  for (int64_t k = 0; k < net.steps; ++k) {
    if (!states[k]) continue;
    for (int64_t l = 0; l < net.layers; ++l) {
      auto& ih = input_h[k * net.layers + l];
      ih.narrow(1, ih.size(1) - h, h).copy_(std::get<0>(*states[k])[l]);
      cell[k * net.layers + l].narrow(1, 0, h).copy_(std::get<1>(*states[k])[l]);
    }
  }
}

void MoGlowStream::draw_noise() {
  // Row by row from each character's own generator (torch::randn({D}, generator) per frame).
  for (int64_t k = 0; k < batch; ++k) noise[k].normal_(0.0, 1.0, generators[k]);
  x.copy_(noise);
  x.mul_(temperature);
}

void MoGlowStream::lstm_layer(int64_t k, int64_t l) {
  const int64_t h = net.hidden, i = k * net.layers + l;
  auto& ih = input_h[i];
  auto g4 = gates.narrow(1, 0, 4 * h);
  if (l == 0) {
    ih.narrow(1, 0, net.d_lo).copy_(x.narrow(1, 0, net.d_lo));
    at::addmm_out(g4, gates_cond.narrow(1, k * 4 * h, 4 * h), ih, net.w_rec[i]);
  } else {
    const auto& below = input_h[i - 1];
    ih.narrow(1, 0, h).copy_(below.narrow(1, below.size(1) - h, h));
    at::addmm_out(g4, net.b_rec[i], ih, net.w_rec[i]);
  }
  gates.sigmoid_();  // whole padded rows: i, f, sigmoid(2g), o
  auto in_gate = gates.narrow(1, 0, h), forget = gates.narrow(1, h, h), g = gates.narrow(1, 2 * h, h),
       out_gate = gates.narrow(1, 3 * h, h);
  g.mul_(2.0).sub_(1.0);  // tanh(g)
  auto c = cell[i].narrow(1, 0, h);
  c.mul_(forget).addcmul_(in_gate, g);
  at::tanh_out(tanh_c, cell[i]);  // whole padded rows
  auto h_out = ih.narrow(1, ih.size(1) - h, h);
  at::mul_out(h_out, out_gate, tanh_c.narrow(1, 0, h));
}

void MoGlowStream::reverse_step(int64_t k) {
  for (int64_t l = 0; l < net.layers; ++l) lstm_layer(k, l);
  const auto& top = input_h[k * net.layers + net.layers - 1];
  at::addmm_out(out, net.b_out[k], top.narrow(1, top.size(1) - net.hidden, net.hidden), net.w_out[k]);
  auto scale = out.narrow(1, 0, net.scale_cols);
  scale.sigmoid_().add_(net.scale_eps);  // s = sigmoid(h + 2) + eps, +2 in the bias
  auto hi = x.narrow(1, net.d_lo, net.d_hi);
  hi.div_(scale.narrow(1, 0, net.d_hi)).sub_(out.narrow(1, net.scale_cols, net.d_hi));
  at::addmm_out(x_next, net.b_rev[k], x, net.w_rev[k]);
  std::swap(x, x_next);
}

void MoGlowStream::shift_history() {
  const int64_t d = pose_dim, c = control_dim;
  cond_next.narrow(1, 0, (tau - 1) * d).copy_(cond.narrow(1, d, (tau - 1) * d));
  cond_next.narrow(1, (tau - 1) * d, d).copy_(x);
  cond_next.narrow(1, tau * d, tau * c).copy_(cond.narrow(1, tau * d + c, tau * c));
  std::swap(cond, cond_next);
}

torch::Tensor MoGlowStream::step(const torch::Tensor& control, const torch::Tensor& lookahead) {
  torch::NoGradGuard no_grad;
  const int64_t d = pose_dim, c = control_dim;
  cond.narrow(1, tau * d + tau * c, c).copy_(control);
  if (lookahead_dim > 0) cond.narrow(1, cond.size(1) - lookahead_dim, lookahead_dim).copy_(lookahead);
  at::addmm_out(gates_cond, net.b_cond, cond, net.w_cond);
  draw_noise();
  for (int64_t k = net.steps - 1; k >= 0; --k) reverse_step(k);
  // Residual: the flow gave x_t minus the previous frame (the history's newest) carried along.
  if (transport) x.add_(transport->apply(cond.narrow(1, (tau - 1) * d, d), control));
  shift_history();
  return x.clone();
}

void MoGlowStream::copy_row(int64_t row, const MoGlowStream& src, int64_t src_row) {
  torch::NoGradGuard no_grad;
  if (src.cond.size(1) != cond.size(1) || src.input_h.size() != input_h.size())
    throw Error("moglow stream: rows of streams of different models");
  if (row < 0 || row >= batch || src_row < 0 || src_row >= src.batch)
    throw Error("moglow stream: row " + std::to_string(row) + " out of range");
  cond[row].copy_(src.cond[src_row]);
  cond_next[row].copy_(src.cond_next[src_row]);
  for (size_t i = 0; i < input_h.size(); ++i) {
    input_h[i][row].copy_(src.input_h[i][src_row]);
    cell[i][row].copy_(src.cell[i][src_row]);
  }
  generators[row] = src.generators[src_row].clone();
}

}  // namespace mosyn::nn
