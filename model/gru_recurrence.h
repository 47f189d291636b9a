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

#include <vector>

namespace mm {

// The weights of one GRU layer as in torch::nn::GRU / GRUCell.
struct GruWeights {
  at::Tensor weight_ih, bias_ih;  // (3H, I), (3H)
  at::Tensor weight_hh, bias_hh;  // (3H, H), (3H)
};

// Runs the GRU over inputs (B, T, I) from h0 (B, H); returns the last hidden
// state (B, H). Differentiable in inputs, h0 and the weights.
at::Tensor gru_last_hidden(const at::Tensor& inputs, const at::Tensor& h0, const GruWeights& gru);

// The weights of K decoders of one shape, stacked: every tensor of
// GruWeights and the output layer gets a leading dimension K.
struct AutoregressiveWeights {
  GruWeights gru;                    // (K, 3H, I), (K, 3H), (K, 3H, H), (K, 3H)
  at::Tensor weight_out, bias_out;   // (K, D, H), (K, D)
  std::vector<bool> residual;        // K flags: whether the decoder adds its previous output
};

// The autoregressive decoder recurrence of Eq. 2-3 and 5-6 for K decoders at
// once: from h0 (K, B, H), each step's input is the decoder's previous output
// pose (zero at first), followed by `code` (B, L) when feed_code; the output
// pose is y = W_o h + b_o (+ previous y where residual). Returns
// (K, T, B, D) in generation order. Differentiable in h0, code and all
// weights. Running the rotation and velocity decoders together halves the
// kernels per step, which sets the time of a training step on a GPU.
at::Tensor gru_autoregressive(const at::Tensor& h0, const at::Tensor& code, const AutoregressiveWeights& weights,
                              int64_t frames, bool feed_code);

}  // namespace mm
