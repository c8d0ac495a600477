#include "nn/mojo/dct.h"

#include <cmath>

#include "core/error.h"

namespace mosyn::nn::mojo {

torch::Tensor dct_matrix(int64_t n) {
  if (n < 1) throw Error("dct_matrix: N must be >= 1, not " + std::to_string(n));
  auto c = torch::empty({n, n}, torch::kFloat64);
  auto a = c.accessor<double, 2>();
  for (int64_t k = 0; k < n; ++k) {
    const double s = std::sqrt((k == 0 ? 1.0 : 2.0) / static_cast<double>(n));
    for (int64_t i = 0; i < n; ++i) a[k][i] = s * std::cos(M_PI * (2.0 * i + 1.0) * k / (2.0 * n));
  }
  return c;
}

torch::Tensor dct_time(const torch::Tensor& x) {
  if (x.dim() != 3) throw Error("dct_time: x must be [B, N, F]");
  const auto c = dct_matrix(x.size(1)).to(x.options());
  return torch::matmul(c, x);  // [N, N] x [B, N, F] -> [B, N, F]
}

torch::Tensor idct_time(const torch::Tensor& bands) {
  if (bands.dim() != 3) throw Error("idct_time: bands must be [B, N, F]");
  const auto c = dct_matrix(bands.size(1)).to(bands.options());
  return torch::matmul(c.t(), bands);
}

}  // namespace mosyn::nn::mojo
