// The LSGAN discriminator of supplementary A.3: four 1-D convolutions over
// time. Layers 1-3: kernel 4, stride 2, reflect padding 1, leaky ReLU 0.2
// (32, 64, 128 channels; batch norm on layers 2 and 3); layer 4: kernel 1,
// one channel, ReLU.
//
// Thread safety: as Encoder.
#pragma once

#include <torch/nn/module.h>
#include <torch/nn/modules/batchnorm.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/pimpl.h>

namespace mm {

class DiscriminatorImpl : public torch::nn::Module {
 public:
  explicit DiscriminatorImpl(int pose_dims);

  // motion: (B, T, pose_dims) normalised poses. Returns (B): the mean over
  // time of the last layer, trained towards 1 for real and 0 for generated
  // motion (Eq. 13).
  at::Tensor forward(const at::Tensor& motion);

  // The last layer's output at each of its time steps, (B, T / 8): what
  // forward() averages, and what the reference implementation's loss squares
  // before averaging.
  at::Tensor step_scores(const at::Tensor& motion);

 private:
  torch::nn::Conv1d conv1_{nullptr}, conv2_{nullptr}, conv3_{nullptr}, conv4_{nullptr};
  torch::nn::BatchNorm1d norm2_{nullptr}, norm3_{nullptr};
};
TORCH_MODULE(Discriminator);

}  // namespace mm
