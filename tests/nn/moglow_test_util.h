// Helpers shared by the MoGlow tests (test_moglow.cpp, test_moglow_heel_terms.cpp).
#pragma once

#include <torch/torch.h>

#include "nn/moglow/moglow.h"

namespace mosyn::nn::testing {

// Makes a freshly built model non-trivial: random ActNorm and coupling output weights.
inline void randomise(MoGlowImpl& model, double scale = 0.3) {
  torch::NoGradGuard no_grad;
  for (auto& s : model.steps) {
    s->actnorm->bias.normal_(0, scale);
    s->actnorm->logs.normal_(0, scale);
    s->actnorm->initialized_flag.fill_(1);
    s->coupling->out->weight.normal_(0, scale);
    s->coupling->out->bias.normal_(0, scale);
  }
}

}  // namespace mosyn::nn::testing
