#include "model/discriminator.h"

#include <ATen/ATen.h>

namespace mm {
namespace {

torch::nn::Conv1dOptions downsampling(int in, int out) {
  return torch::nn::Conv1dOptions(in, out, 4).stride(2).padding(1).padding_mode(torch::kReflect);
}

}  // namespace

DiscriminatorImpl::DiscriminatorImpl(int pose_dims)
    : conv1_(register_module("conv1", torch::nn::Conv1d(downsampling(pose_dims, 32)))),
      conv2_(register_module("conv2", torch::nn::Conv1d(downsampling(32, 64)))),
      conv3_(register_module("conv3", torch::nn::Conv1d(downsampling(64, 128)))),
      conv4_(register_module("conv4", torch::nn::Conv1d(torch::nn::Conv1dOptions(128, 1, 1)))),
      norm2_(register_module("norm2", torch::nn::BatchNorm1d(64))),
      norm3_(register_module("norm3", torch::nn::BatchNorm1d(128))) {}

at::Tensor DiscriminatorImpl::forward(const at::Tensor& motion) { return step_scores(motion).mean(1); }

at::Tensor DiscriminatorImpl::step_scores(const at::Tensor& motion) {
  auto x = motion.transpose(1, 2);  // convolve over time: (B, dims, T)
  x = at::leaky_relu(conv1_->forward(x), 0.2);
  x = at::leaky_relu(norm2_->forward(conv2_->forward(x)), 0.2);
  x = at::leaky_relu(norm3_->forward(conv3_->forward(x)), 0.2);
  x = at::relu(conv4_->forward(x));
  return x.squeeze(1);
}

}  // namespace mm
