// MoGlow's frame-by-frame generation for inference (begin_stream, step_stream and sample all run
// it): the flow's reverse direction (FlowStep::reverse, step K-1 down to 0) for a batch of
// characters, with the weights rearranged once per stream so that one frame of B characters is
//   - one GEMM [B, cond_dim] x [cond_dim, K * 4H] for the conditioning part of every step's first
//     LSTM layer (the bulk of the arithmetic: the conditioning is the same for all K steps), and
//   - per step three small GEMMs (the coupling half and h through the LSTM, h through the output
//     layer, the inverse linear map with the ActNorm reverse folded in) and a few element-wise ops,
// all in buffers allocated once. Equal to FlowStep::reverse up to float rounding
// (tests/nn/test_moglow.cpp recovers the drawn noise through the reference forward direction).
//
// Characters are independent: each draws its noise from its own generator and every operation
// works row by row, so a character's frames are the same alone or in any batch up to float
// rounding (tests/nn/test_crowd.cpp). Not bit for bit: OpenBLAS rounds a row of a product
// differently in matrices of other heights (about 1e-6 relative; measured), although the rows of
// the buffers that transcendental functions run over are padded to 64 floats so vectorised loops
// treat every row alike. The same batch replays bit for bit.
#pragma once

#include <ATen/core/Generator.h>
#include <torch/types.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "nn/moglow/moglow.h"

namespace mosyn::nn {

// The weights of a MoGlow rearranged for inference (no gradient, the model's dtype and device),
// taken from the model at one time.
// H = hidden units, L = LSTM layers, K = flow steps; index k * L + l is step k's layer l.
struct MoGlowInference {
  int64_t steps = 0, layers = 0, hidden = 0, dim = 0, d_lo = 0, d_hi = 0;
  int64_t gate_cols = 0;   // 4H padded to a multiple of 64
  int64_t cell_cols = 0;   // H padded to a multiple of 64
  int64_t scale_cols = 0;  // d_hi padded to a multiple of 64
  // Conditioning columns of every step's first-layer input weights, transposed: [cond_dim, K * 4H]
  // (step k at columns k * 4H), and the first layers' biases b_ih + b_hh [K * 4H]. The g gate's
  // weights and bias are doubled throughout: tanh(g) = 2 sigmoid(2g) - 1, so one sigmoid covers
  // all four gates.
  torch::Tensor w_cond, b_cond;
  // Per step and layer: [in_l + H, 4H], the rest of W_ih (the coupling's lower half for l = 0,
  // the layer below's h else) stacked on W_hh, transposed; b_rec: b_ih + b_hh [4H] (l > 0 only).
  std::vector<torch::Tensor> w_rec, b_rec;
  // Per step: the coupling's output layer, transposed, [H, scale_cols + d_hi]: columns 0..d_hi-1
  // give the scale's pre-activation (bias + 2 folded in), columns scale_cols.. the shift.
  std::vector<torch::Tensor> w_out, b_out;
  // Per step: InvLinear's reverse and ActNorm's reverse as one affine map,
  // a = b W^-T diag(exp(-logs)) - bias: w_rev [D, D], b_rev [D].
  std::vector<torch::Tensor> w_rev, b_rev;
  double scale_eps = 0;

  static MoGlowInference of(MoGlowImpl& model);
};

// A MoGlow stream: per character its conditioning row, every LSTM's state and a noise generator.
struct MoGlowStream : StreamState {
  std::shared_ptr<const MoGlowInference> shared_net;  // MoGlowImpl::inference(), shared by every stream
  const MoGlowInference& net;
  int64_t batch = 0, tau = 0, pose_dim = 0, control_dim = 0, label_dim = 0, lookahead_dim = 0;
  double temperature = 1.0;
  // MoGlowOptions::residual: each frame adds the transported previous one (nullopt without).
  std::optional<PoseTransport> transport;
  torch::TensorOptions options;  // the model's dtype and device
  // [B, cond_dim], MoGlowImpl::conditioning's layout for one frame: pose history (tau x D, oldest
  // first), controls (tau + 1 x C, the frame being generated last), labels, look-ahead features.
  // cond_next receives the shifted history of the next frame.
  torch::Tensor cond, cond_next;
  // Per step and layer [B, in_l + H]: the layer's input (written each frame), then its h.
  std::vector<torch::Tensor> input_h;
  std::vector<torch::Tensor> cell;  // per step and layer [B, cell_cols], c in the first H columns
  std::vector<at::Generator> generators;  // per row, CPU
  // Scratch: gates of all first layers [B, K * 4H]; one layer's gates [B, gate_cols]; tanh(c)
  // [B, cell_cols]; the output layer [B, scale_cols + d_hi]; the flow variable x and the next
  // [B, D]; the noise [B, D] (CPU).
  torch::Tensor gates_cond, gates, tanh_c, out, x, x_next, noise;

  // Zero state for `batch` rows of `model`, generators seeded with seeds[k].
  MoGlowStream(MoGlowImpl& model, int64_t batch, const std::vector<std::uint64_t>& seeds);

  // Row k's pose history [tau, D], control history [tau, C] (standardised, oldest first) and
  // labels [label_dim], each tensor [B, ...]; labels undefined = zeros.
  void set_history(const torch::Tensor& pose_hist, const torch::Tensor& ctrl_hist, const torch::Tensor& labels);
  // Every step's LSTM state (h, c), each [L, B, H], as encode() leaves it (a prefix's warm-up).
  void set_lstm_states(const std::vector<c10::optional<LstmState>>& states);

  // One frame: control [B, C] standardised, look-ahead [B, lookahead_dim] (undefined without)
  // -> pose [B, D] standardised (a new tensor).
  torch::Tensor step(const torch::Tensor& control, const torch::Tensor& lookahead);

  // Row `row` takes over row src_row of src (same model): conditioning, LSTM states, generator.
  void copy_row(int64_t row, const MoGlowStream& src, int64_t src_row);

 private:
  // Step k of the flow in reverse on x, gates of its first layer already in gates_cond.
  void reverse_step(int64_t k);
  // One LSTM layer (step k, layer l) from its input in input_h; h written back there.
  void lstm_layer(int64_t k, int64_t l);
  // Draws every row's noise into x (times the temperature).
  void draw_noise();
  // The next frame's conditioning from this one's and the new pose x.
  void shift_history();
};

}  // namespace mosyn::nn
