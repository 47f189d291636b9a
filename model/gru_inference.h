// The GRU arithmetic of torch::nn::GRU / GRUCell for inference, over raw
// CPU float buffers: no autograd graph and, at batch 1, matrix-vector
// products that stream the weights once. Shared by the encoder's and the
// decoders' fast paths.
//
// Thread safety: pure functions of their arguments.
#pragma once

#include <ATen/ATen.h>

namespace mm {

// out (B, N) = bias (N) + input (B, K) . weight (N, K)^T.
void affine_into(at::Tensor& out, const at::Tensor& bias, const at::Tensor& weight, const at::Tensor& input);

// One GRU step in place: hidden (B, H) <- GRU(hidden, x) given the input's
// gate pre-activations input_gates (B, 3H) = b_ih + x . W_ih^T. hidden_gates
// (B, 3H) is scratch space. Gate order r, z, n as in PyTorch.
void gru_update(at::Tensor& hidden, const at::Tensor& input_gates, at::Tensor& hidden_gates, const at::Tensor& weight_hh,
                const at::Tensor& bias_hh);

// The same step's element-wise part, given both gate pre-activations
// (hidden_gates = b_hh + hidden . W_hh^T): for callers that compute the
// products themselves (packed_linear.h). One fused pass over CPU float rows
// (each row's values contiguous), with its own e^x: the new state lies
// within 1.2e-7 of LibTorch's sigmoid and tanh (GruCombine test).
void gru_combine(at::Tensor& hidden, const at::Tensor& input_gates, const at::Tensor& hidden_gates);

}  // namespace mm
