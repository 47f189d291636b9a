#include "model/gru_inference.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "model/vector_clones.h"

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

namespace {

// e^x written so that a loop around it vectorises (std::exp is a call per
// element): x = n ln2 + r with |r| <= ln2/2, e^r by its Taylor polynomial to
// r^6 (relative error under 2e-7), 2^n built in the exponent bits. x is
// clamped to where 2^n is a normal float; a NaN stays NaN.
inline float exp_vectorisable(float x) {
  x = std::min(std::max(x, -87.0f), 88.0f);
  constexpr float kRound = 12582912.0f;  // 1.5 * 2^23: adding it rounds to an integer
  const float n = (x * 1.44269504f + kRound) - kRound;
  const float r = (x - n * 0.693145751953125f) - n * 1.42860677e-06f;
  const float p =
      1.0f + r * (1.0f + r * (0.5f + r * (1.0f / 6 + r * (1.0f / 24 + r * (1.0f / 120 + r * (1.0f / 720))))));
  const uint32_t bits = static_cast<uint32_t>(static_cast<int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

inline float sigmoid(float x) { return 1.0f / (1.0f + exp_vectorisable(-x)); }
inline float tanh_vectorisable(float x) { return 2.0f / (1.0f + exp_vectorisable(-2.0f * x)) - 1.0f; }

// Columns [begin, end) of one row: every gate of a column in one pass, so the
// step reads its gates once and makes no LibTorch call per operation (at
// batch 1 those calls cost as much as the arithmetic).
MM_VECTOR_CLONES void combine_columns(float* __restrict hidden, const float* __restrict input_gates,
                                      const float* __restrict hidden_gates, int64_t size, int64_t begin,
                                      int64_t end) {
  for (int64_t j = begin; j < end; ++j) {
    const float reset = sigmoid(input_gates[j] + hidden_gates[j]);
    const float update = sigmoid(input_gates[size + j] + hidden_gates[size + j]);
    const float candidate = tanh_vectorisable(input_gates[2 * size + j] + reset * hidden_gates[2 * size + j]);
    hidden[j] = candidate + update * (hidden[j] - candidate);  // (1 - z) n + z h
  }
}

void require_rows(const at::Tensor& t, int64_t columns, const char* name) {
  if (!t.device().is_cpu() || t.scalar_type() != at::kFloat || t.dim() != 2 || t.size(1) != columns ||
      t.stride(1) != 1) {
    throw std::invalid_argument(std::string("gru_combine: ") + name + " must be CPU float rows of " +
                                std::to_string(columns) + " contiguous values");
  }
}

}  // namespace

void gru_combine(at::Tensor& hidden, const at::Tensor& input_gates, const at::Tensor& hidden_gates) {
  const int64_t batch = hidden.size(0), size = hidden.size(1);
  require_rows(hidden, size, "hidden");
  require_rows(input_gates, 3 * size, "input_gates");
  require_rows(hidden_gates, 3 * size, "hidden_gates");
  float* h = hidden.data_ptr<float>();
  const float* in = input_gates.data_ptr<float>();
  const float* hg = hidden_gates.data_ptr<float>();
  const int64_t h_stride = hidden.stride(0), in_stride = input_gates.stride(0), hg_stride = hidden_gates.stride(0);
  // Split over the threads only where a batch is large enough to pay for it.
  at::parallel_for(0, batch * size, 16384, [&](int64_t begin, int64_t end) {
    for (int64_t at = begin; at < end;) {
      const int64_t row = at / size, column = at % size, stop = std::min(end - row * size, size);
      combine_columns(h + row * h_stride, in + row * in_stride, hg + row * hg_stride, size, column, stop);
      at = row * size + stop;
    }
  });
}

}  // namespace mm
