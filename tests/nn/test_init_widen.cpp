// --init-from into a wider model: a run's recurrent layers grown to more hidden units start out
// computing exactly what the stored run did, and the new units learn.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include <unistd.h>

#include "nn/checkpoint.h"
#include "nn/registry.h"
#include "nn/trainable.h"
#include "nn_test_util.h"

using namespace mosyn;
using namespace mosyn::nn;
namespace fs = std::filesystem;
using nn::testing::kDim;

namespace {

nlohmann::json moglow_config(int hidden) {
  return {{"num_steps", 2}, {"hidden", hidden}, {"lstm_layers", 2}, {"tau", 2}, {"dropout", 0.0}};
}

// Every parameter of a fresh MoGlow moved off its initialisation (the couplings' output layers
// start at zero, which would hide whether the LSTMs were copied right).
void perturb(torch::nn::Module& m) {
  torch::NoGradGuard no_grad;
  for (auto& p : m.parameters()) p.add_(0.3 * torch::randn_like(p));
}

double loss_of(TrainableModel& m, const Batch& batch) {
  m.eval();
  torch::NoGradGuard no_grad;
  return m.loss(batch).loss().item<double>();
}

}  // namespace

// Hidden 8 -> 13 in both LSTM layers of each coupling: the same loss to float precision before any
// step; the new units' incoming weights are not zero (not dead), the stored units' weights from the
// new units are; one gradient step reaches the output columns of the new units.
TEST(InitWiden, WiderRecurrentLayersStartAsTheStoredModel) {
  torch::manual_seed(5);
  const ModelContext ctx = nn::testing::small_context(kDim, 3);
  auto narrow = create_trainable("moglow", moglow_config(8), ctx);
  perturb(*narrow);
  const fs::path path = fs::temp_directory_path() / ("mosyn_widen_" + std::to_string(::getpid()) + ".pt");
  save_checkpoint(path.string(), *narrow, nullptr, CheckpointState{});

  auto wide = create_trainable("moglow", moglow_config(13), ctx);
  const InitReport report = init_from_checkpoint(path.string(), *wide, torch::kCPU);
  EXPECT_TRUE(report.missing.empty());
  // Per coupling: 4 tensors of each of 2 LSTM layers, and the output layer's weight.
  EXPECT_EQ(report.grown.size(), 2u * (4 * 2 + 1));

  const auto batch = nn::testing::noisy_sinusoid_batch(3, 12, kDim);
  EXPECT_NEAR(loss_of(*wide, batch), loss_of(*narrow, batch), 1e-5);

  auto params = wide->named_parameters();
  auto stored = narrow->named_parameters();
  for (const std::string layer : {"l0", "l1"}) {
    const std::string prefix = "step0.coupling.lstm.";
    auto hh = params[prefix + "weight_hh_" + layer];
    auto hh_stored = stored[prefix + "weight_hh_" + layer];
    for (int g = 0; g < 4; ++g) {
      // Gate g: the stored units' rows in the first 8 rows of its block, reading no new unit.
      EXPECT_TRUE(torch::equal(hh.narrow(0, g * 13, 8).narrow(1, 0, 8), hh_stored.narrow(0, g * 8, 8)));
      EXPECT_EQ(hh.narrow(0, g * 13, 8).narrow(1, 8, 5).abs().max().item<float>(), 0.0f);
      EXPECT_GT(hh.narrow(0, g * 13 + 8, 5).abs().max().item<float>(), 0.0f);
    }
  }

  wide->train();
  auto out_weight = params["step0.coupling.out.weight"];
  ASSERT_TRUE(out_weight.defined());
  wide->zero_grad();
  wide->loss(batch).loss().backward();
  EXPECT_GT(out_weight.grad().narrow(1, 8, 5).abs().max().item<float>(), 0.0f);
  fs::remove(path);
}

// Narrower than stored is not a widening: the layer is left as initialised and reported.
TEST(InitWiden, NarrowerRecurrentLayersAreLeftAsInitialised) {
  torch::manual_seed(6);
  const ModelContext ctx = nn::testing::small_context(kDim, 3);
  auto wide = create_trainable("moglow", moglow_config(13), ctx);
  const fs::path path = fs::temp_directory_path() / ("mosyn_narrow_" + std::to_string(::getpid()) + ".pt");
  save_checkpoint(path.string(), *wide, nullptr, CheckpointState{});
  auto narrow = create_trainable("moglow", moglow_config(8), ctx);
  const InitReport report = init_from_checkpoint(path.string(), *narrow, torch::kCPU);
  EXPECT_FALSE(report.missing.empty());
  EXPECT_TRUE(report.grown.empty());
  fs::remove(path);
}

namespace {

// A two-layer GRU (3 gates) and a linear readout: the families with GRUs (mojo, dfn, hvrnn) widen
// through the same code as the LSTMs above, and this checks the 3-gate layout alone.
class GruReadout : public TrainableModel {
 public:
  explicit GruReadout(int hidden)
      : TrainableModel("GruReadout"),
        hidden_(hidden),
        gru_(register_module("gru", torch::nn::GRU(torch::nn::GRUOptions(kInputs, hidden).num_layers(2)
                                                        .batch_first(true)))),
        out_(register_module("out", torch::nn::Linear(hidden, 2))) {}
  std::string family() const override { return "test-gru"; }
  nlohmann::json config() const override { return {{"hidden", hidden_}}; }
  torch::Tensor forward(const torch::Tensor& x) { return out_(std::get<0>(gru_(x))); }  // [B, T, 2]
  LossTerms loss(const Batch& batch) override {
    LossTerms terms;
    terms.terms["loss"] = forward(batch.control).pow(2).mean();
    return terms;
  }
  static constexpr int kInputs = 3;

 private:
  int hidden_;
  torch::nn::GRU gru_;
  torch::nn::Linear out_;
};

}  // namespace

// Hidden 5 -> 9 in both GRU layers: the same readout to float precision; per gate the stored rows
// sit first in their block, the stored units read no new unit, and the new units are not dead.
TEST(InitWiden, WiderGruLayersStartAsTheStoredModel) {
  torch::manual_seed(7);
  GruReadout narrow(5);
  perturb(narrow);
  const fs::path path = fs::temp_directory_path() / ("mosyn_widen_gru_" + std::to_string(::getpid()) + ".pt");
  save_checkpoint(path.string(), narrow, nullptr, CheckpointState{});
  GruReadout wide(9);
  const InitReport report = init_from_checkpoint(path.string(), wide, torch::kCPU);
  EXPECT_TRUE(report.missing.empty());
  EXPECT_EQ(report.grown.size(), 4u * 2 + 1);  // 4 tensors of each GRU layer, the readout's weight
  const auto x = torch::randn({2, 6, GruReadout::kInputs});
  torch::NoGradGuard no_grad;
  EXPECT_TRUE(torch::allclose(wide.forward(x), narrow.forward(x), 1e-5, 1e-6));
  auto params = wide.named_parameters();
  auto stored = narrow.named_parameters();
  const auto hh = params["gru.weight_hh_l1"], hh_stored = stored["gru.weight_hh_l1"];
  for (int g = 0; g < 3; ++g) {
    EXPECT_TRUE(torch::equal(hh.narrow(0, g * 9, 5).narrow(1, 0, 5), hh_stored.narrow(0, g * 5, 5)));
    EXPECT_EQ(hh.narrow(0, g * 9, 5).narrow(1, 5, 4).abs().max().item<float>(), 0.0f);
    EXPECT_GT(hh.narrow(0, g * 9 + 5, 4).abs().max().item<float>(), 0.0f);
  }
  fs::remove(path);
}
