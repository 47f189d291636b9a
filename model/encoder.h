// The encoder of Sec. 3.2.1: a GRU over the clip, then one linear layer from
// its last hidden state to the manifold code z (Eq. 1).
//
// Thread safety: forward() on a module in eval mode under NoGradGuard may be
// called concurrently; training is single-threaded.
#pragma once

#include <torch/nn/module.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>
#include <torch/nn/pimpl.h>

#include <memory>

#include "model/gru_recurrence.h"
#include "model/inference_precision.h"

namespace mm {

class EncoderImpl : public torch::nn::Module {
 public:
  EncoderImpl(int pose_dims, int hidden, int latent);

  // motion: (B, T, pose_dims) normalised poses in time order. Returns (B, latent).
  // Training path: one fused recurrence with a whole-sequence backward pass
  // (gru_recurrence.h).
  at::Tensor forward(const at::Tensor& motion);

  // The same function through torch::nn::GRU: the reference the fused paths
  // are tested against, and encode()'s path off the CPU.
  at::Tensor forward_reference(const at::Tensor& motion);

  // Same result as forward() for inference: no autograd graph and, on the
  // CPU, a fused GRU loop (see gru_inference.h). Safe to call concurrently.
  at::Tensor encode(const at::Tensor& motion) const;

  // Packs the weights encode() multiplies with, once, in `precision`
  // (packed_linear.h); encode() uses them on the CPU from then on, until
  // the weights change (training), when it goes back to them as they are.
  // Not concurrently with encode().
  void pack_for_inference(Precision precision);
  void discard_inference_pack() { packed_.reset(); }

 private:
  struct Packed;
  GruWeights weights() const;
  std::shared_ptr<const Packed> packed_;

  torch::nn::GRU gru_{nullptr};
  torch::nn::Linear to_code_{nullptr};
};
TORCH_MODULE(Encoder);

}  // namespace mm
