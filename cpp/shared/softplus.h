// Softplus as PyTorch computes it (torch.nn.Softplus, beta = 1, threshold = 20):
//   softplus(x) = x                  for x > 20  (where log1p(e^x) = x to float
//   precision)
//                 log1p(exp(x))      otherwise.
// The activation of every hidden layer of the decoders (docs/model-format.md).
#pragma once

#include <cmath>

namespace sss {

constexpr float kSoftplusThreshold = 20.f;

inline float softplus(float x) {
    return x > kSoftplusThreshold ? x : std::log1p(std::exp(x));
}

}  // namespace sss
