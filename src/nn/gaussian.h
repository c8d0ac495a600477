// Diagonal Gaussians, shared by every family with latent variables (rvae, hvrnn, dfn): closed-form
// KL divergences and log-densities, parameterised by mean and log-variance.
#pragma once

#include <torch/types.h>

#include "nn/config_json.h"

namespace mosyn::nn {

// KL(N(q_mean, exp(q_logvar)) || N(p_mean, exp(p_logvar))) in nats, summed over the last dimension
// (shapes broadcast).
inline torch::Tensor diagonal_gaussian_kl(const torch::Tensor& q_mean, const torch::Tensor& q_logvar,
                                          const torch::Tensor& p_mean, const torch::Tensor& p_logvar) {
  return 0.5 * (p_logvar - q_logvar + (q_logvar.exp() + (q_mean - p_mean).pow(2)) / p_logvar.exp() - 1.0).sum(-1);
}

// log N(x; mean, exp(logvar)) in nats, summed over the last dimension.
inline torch::Tensor diagonal_gaussian_log_density(const torch::Tensor& x, const torch::Tensor& mean,
                                                   const torch::Tensor& logvar) {
  return -0.5 * (kLog2Pi + logvar + (x - mean).pow(2) / logvar.exp()).sum(-1);
}

}  // namespace mosyn::nn
