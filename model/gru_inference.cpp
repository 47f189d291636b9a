#include "gru_inference.h"

namespace mm {

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
  gru_combine(hidden, input_gates, hidden_gates);
}

void gru_combine(at::Tensor& hidden, const at::Tensor& input_gates, at::Tensor& hidden_gates) {
  // Whole-row operations in place in the scratch gates: LibTorch's
  // element-wise kernels are vectorised (a scalar loop of sigmoid and tanh
  // took as long as the products at batch 30).
  const int64_t size = hidden.size(1);
  auto reset_update = hidden_gates.narrow(1, 0, 2 * size);
  reset_update.add_(input_gates.narrow(1, 0, 2 * size)).sigmoid_();
  auto candidate = hidden_gates.narrow(1, 2 * size, size);
  candidate.mul_(reset_update.narrow(1, 0, size)).add_(input_gates.narrow(1, 2 * size, size)).tanh_();
  // h' = (1 - z) n + z h = n + z (h - n)
  hidden.sub_(candidate).mul_(reset_update.narrow(1, size, size)).add_(candidate);
}

}  // namespace mm
