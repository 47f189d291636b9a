// Whole-sequence GRU recurrences with a hand-written backward pass (BPTT),
// for training. Autograd over a loop of GRU cells accumulates every weight
// gradient once per time step: 150 rank-B updates of each 3072 x 1024
// matrix, which is memory-bound and dominates a training step at small
// batches. Here the backward pass collects the gate gradients of all steps
// and forms each weight gradient with one matrix product.
//
// Both functions compute exactly what a loop of torch::nn::GRUCell steps
// computes (gate order r, z, n) and work on any device.
//
// Thread safety: pure functions of their arguments.
#pragma once

#include <ATen/ATen.h>

namespace mm {

// The weights of one GRU layer as in torch::nn::GRU / GRUCell.
struct GruWeights {
  at::Tensor weight_ih, bias_ih;  // (3H, I), (3H)
  at::Tensor weight_hh, bias_hh;  // (3H, H), (3H)
};

// Runs the GRU over inputs (B, T, I) from h0 (B, H); returns the last hidden
// state (B, H). Differentiable in inputs, h0 and the weights.
at::Tensor gru_last_hidden(const at::Tensor& inputs, const at::Tensor& h0, const GruWeights& gru);

// The autoregressive decoder recurrence of Eq. 2-3 and 5-6: from h0 (B, H),
// each step's input is the previous output pose (zero at first), followed by
// `code` (B, L) when feed_code; the output pose is
// y = W_o h + b_o (+ previous y when residual). Returns (T, B, D) in
// generation order. Differentiable in h0, code and all weights.
at::Tensor gru_autoregressive(const at::Tensor& h0, const at::Tensor& code, const GruWeights& gru,
                              const at::Tensor& weight_out, const at::Tensor& bias_out, int64_t frames, bool residual,
                              bool feed_code);

}  // namespace mm
