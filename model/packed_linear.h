// A linear layer for inference on the CPU whose weights are packed once, in
// the layout and number format the CPU's matrix kernels read fastest
// (oneDNN's matmul), instead of being repacked by every general matrix
// product: at batch 30 a GRU step's products spend as long repacking the
// 12 MB weight as multiplying with it. In int8 the weights are quantised
// with one scale per output row and each input row with its own scale at
// every call (inference_precision.h). Without oneDNN at build time it falls
// back to LibTorch's products, fp32 only.
//
// Thread safety: apply() may be called concurrently; each call uses its
// own scratch memory.
#pragma once

#include <ATen/ATen.h>

#include <memory>

#include "model/inference_precision.h"

namespace mm {

class PackedLinear {
 public:
  // weight (N, K), bias (N): float CPU tensors, read now. InputError if
  // the precision is not available here (precision_available).
  PackedLinear(const at::Tensor& weight, const at::Tensor& bias, Precision precision);
  ~PackedLinear();
  PackedLinear(const PackedLinear&) = delete;
  PackedLinear& operator=(const PackedLinear&) = delete;

  // out (rows, N) = bias + input (rows, K) . weight^T; input and out are
  // contiguous float CPU tensors (out preallocated).
  void apply(const at::Tensor& input, at::Tensor& out) const;

  // False once the weight or bias it was packed from changed in place
  // (an optimiser step): the packed copy is then stale. Weights made inside
  // c10::InferenceMode carry no change count and count as current.
  bool current() const;

  Precision precision() const { return precision_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  Precision precision_;
  at::Tensor weight_, bias_;  // the source, for current() and the fallback
  int64_t weight_version_, bias_version_;
};

}  // namespace mm
