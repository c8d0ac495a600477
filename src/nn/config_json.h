// Constants shared by the model families' objectives. Reading and writing a family's JSON config
// is nn/options_fields.h (one field list per family). Header-only; no LibTorch.
#pragma once

namespace mosyn::nn {

// log(2 pi), the Gaussian normalising constant per dimension (nats).
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

}  // namespace mosyn::nn
