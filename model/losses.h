// The loss terms of Sec. 3.3, one function per equation. Each returns a
// scalar tensor with gradients to its inputs.
//
// Thread safety: pure functions; safe to call concurrently.
#pragma once

#include <ATen/ATen.h>

namespace mm {

// Eq. 9 for one decoder: mean over clips and frames of the Euclidean norm of
// the pose error. q_hat, q: (B, T, D) normalised poses.
at::Tensor angle_loss(const at::Tensor& q_hat, const at::Tensor& q);

// Eq. 10 for one decoder: mean over clips and frames of the Euclidean norm of
// the joint position error over all joints. p_hat, p: (B, T, J, 3) in the
// model's position unit (millimetres divided by one scale for all joints).
at::Tensor position_loss(const at::Tensor& p_hat, const at::Tensor& p);

// Eq. 11 for one decoder: mean absolute difference between the codes z and
// z_hat = Enc(Dec(z)), both (B, latent).
at::Tensor manifold_loss(const at::Tensor& z_hat, const at::Tensor& z);

// Eq. 12: maximum mean discrepancy between encoded codes and prior samples,
// both (B, latent), with the inverse multiquadratic kernel
// k(x, y) = C / (C + |x - y|^2), C = 2 * latent * prior_variance; the
// unbiased estimator (diagonal terms left out). Zero in expectation when the
// two sets come from one distribution.
at::Tensor mmd_inverse_multiquadratic(const at::Tensor& codes, const at::Tensor& prior_samples, double prior_variance);

// Eq. 13 (without lambda_G): least-squares discriminator loss on scores of
// real (B) and generated (B) motions.
at::Tensor lsgan_discriminator_loss(const at::Tensor& real_scores, const at::Tensor& fake_scores);

// Eq. 14: least-squares generator loss on the scores of generated motions.
at::Tensor lsgan_generator_loss(const at::Tensor& fake_scores);

}  // namespace mm
