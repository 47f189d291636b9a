// The rotation and velocity decoders of Sec. 3.2.3 (Eq. 2-3 and 5-6).
//
// Both map z through a linear layer to the GRU's initial hidden state and
// then run autoregressively on their own previous output, starting from a
// zero pose, generating the clip in reverse time order. The velocity decoder
// adds its previous output (a residual connection), so it learns per-frame
// changes. With feed_code (variant DKGMZ) each step also sees z.
//
// Thread safety: as Encoder.
#pragma once

#include <torch/nn/module.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/modules/rnn.h>
#include <torch/nn/pimpl.h>

#include <memory>
#include <vector>

#include "model/inference_precision.h"

namespace mm {

struct DecoderShape {
  int pose_dims = 51;
  int hidden = 1024;
  int latent = 64;
  int frames = 150;
  bool residual = false;   // true: velocity decoder
  bool feed_code = false;  // true: [q_{i+1}, z] is the step input
};

class DecoderImpl : public torch::nn::Module {
 public:
  explicit DecoderImpl(const DecoderShape& shape);

  // z: (B, latent). Returns (B, frames, pose_dims) normalised poses in time
  // order (the reverse generation order is undone here). Training path: one
  // fused recurrence with a whole-sequence backward pass (gru_recurrence.h).
  at::Tensor forward(const at::Tensor& z);

  // The same function as a loop of torch::nn::GRUCell steps: the reference
  // the fused paths are tested against, and generate()'s path off the CPU.
  at::Tensor forward_stepwise(const at::Tensor& z);

  // Same result as forward() for inference: no autograd graph, and on the CPU
  // a fused GRU step over raw buffers (matrix-vector products at batch 1),
  // several times faster than forward(). Safe to call concurrently.
  at::Tensor generate(const at::Tensor& z) const;

  const DecoderShape& shape() const { return shape_; }

  // As EncoderImpl::pack_for_inference, for generate().
  void pack_for_inference(Precision precision);
  void discard_inference_pack() { packed_.reset(); }

 private:
  struct Packed;
  std::shared_ptr<const Packed> packed_;
  friend std::vector<at::Tensor> forward_together(const std::vector<DecoderImpl*>& decoders, const at::Tensor& z);

  DecoderShape shape_;
  torch::nn::Linear from_code_{nullptr};
  torch::nn::GRUCell cell_{nullptr};
  torch::nn::Linear to_pose_{nullptr};
};
TORCH_MODULE(Decoder);

// forward() of several decoders of one shape (they may differ in `residual`)
// on the same codes, as one recurrence: the training step runs the rotation
// and velocity decoders this way. One output per decoder, in order.
// InputError if the shapes differ.
std::vector<at::Tensor> forward_together(const std::vector<DecoderImpl*>& decoders, const at::Tensor& z);

}  // namespace mm
