// The orthonormal DCT-II over time, as a matrix: MOJO's latent frequency bands (Zhang et al.
// 2021, Sec. 3.3).
#pragma once

#include <torch/types.h>

namespace mosyn::nn::mojo {

// C [N, N] float64 with C[k][n] = s_k cos(pi (2n + 1) k / (2N)), s_0 = sqrt(1/N), s_k = sqrt(2/N):
// the orthonormal DCT-II, so C C^T = I and the inverse (DCT-III) is C^T. Band k of a sequence
// x [N] is (C x)[k]. Throws mosyn::Error for N < 1.
torch::Tensor dct_matrix(int64_t n);

// Bands of x [B, N, F] over its time axis: [B, N, F] with row k = band k (C x per feature).
torch::Tensor dct_time(const torch::Tensor& x);
// The inverse: a sequence [B, N, F] from its bands [B, N, F] (C^T bands).
torch::Tensor idct_time(const torch::Tensor& bands);

}  // namespace mosyn::nn::mojo
