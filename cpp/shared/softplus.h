// Softplus as PyTorch computes it (torch.nn.Softplus, beta = 1, threshold = 20):
//   softplus(x) = x                  for x > 20  (where log1p(e^x) = x to float
//   precision)
//                 log1p(exp(x))      otherwise.
// The activation of every hidden layer of the decoders (docs/model-format.md). Portable
// (core/portable.h).
#ifndef SSS_SHARED_SOFTPLUS_H
#define SSS_SHARED_SOFTPLUS_H

#ifdef __cplusplus
#include "core/portable.h"
namespace sss {
#endif

SSS_CONST float kSoftplusThreshold = 20.f;

SSS_FN float softplus(float x) { return x > kSoftplusThreshold ? x : log1p(exp(x)); }

#ifdef __cplusplus
}  // namespace sss
#endif

#endif  // SSS_SHARED_SOFTPLUS_H
