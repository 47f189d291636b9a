#include "gru_inference.h"

#include <cmath>

namespace mm {
namespace {

inline float sigmoid(float v) { return 1.0f / (1.0f + std::exp(-v)); }

}  // namespace

void affine_into(at::Tensor& out, const at::Tensor& bias, const at::Tensor& weight, const at::Tensor& input) {
  if (input.size(0) == 1) {
    // The general matrix product path is several times slower for one row.
    auto row = out.select(0, 0);
    at::addmv_out(row, bias, weight, input.select(0, 0));
  } else {
    at::addmm_out(out, bias, input, weight.t());
  }
}

void gru_update(at::Tensor& hidden, const at::Tensor& input_gates, at::Tensor& hidden_gates, const at::Tensor& weight_hh,
                const at::Tensor& bias_hh) {
  affine_into(hidden_gates, bias_hh, weight_hh, hidden);
  const int64_t batch = hidden.size(0), size = hidden.size(1);
  for (int64_t b = 0; b < batch; ++b) {
    const float* gi = input_gates.data_ptr<float>() + b * input_gates.stride(0);
    const float* gh = hidden_gates.data_ptr<float>() + b * 3 * size;
    float* h = hidden.data_ptr<float>() + b * size;
    for (int64_t k = 0; k < size; ++k) {
      const float reset = sigmoid(gi[k] + gh[k]);
      const float update = sigmoid(gi[size + k] + gh[size + k]);
      const float candidate = std::tanh(gi[2 * size + k] + reset * gh[2 * size + k]);
      h[k] = (1.0f - update) * candidate + update * h[k];
    }
  }
}

}  // namespace mm
