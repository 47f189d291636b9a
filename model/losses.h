// The loss terms of Sec. 3.3, one function per equation. Each returns a
// scalar tensor with gradients to its inputs.
//
// Thread safety: pure functions; safe to call concurrently.
#pragma once

#include <ATen/ATen.h>

#include "model/training_config.h"

namespace mm {

// The "frame-norm" angle loss for one decoder: mean over clips and frames of
// the Euclidean norm of a frame's whole pose error. q_hat, q: (B, T, D)
// normalised poses.
at::Tensor angle_loss(const at::Tensor& q_hat, const at::Tensor& q);

// The reference implementation's angle loss: the D values of a frame taken
// as D/3 consecutive triplets, the mean over clips, frames and triplets of
// each triplet's Euclidean norm. InputError if D is not a multiple of 3.
at::Tensor angle_loss_triplet_mean(const at::Tensor& q_hat, const at::Tensor& q);

// Eq. 9 as the paper writes it: the D values of a frame taken as D/3 joints
// (triplets), each joint's Euclidean norm summed over the joints, the mean
// over clips and frames (the reference's triplet mean times D/3).
// InputError if D is not a multiple of 3.
at::Tensor angle_loss_joint_sum(const at::Tensor& q_hat, const at::Tensor& q);

// The angle loss in the form `form` asks for.
at::Tensor angle_loss(const at::Tensor& q_hat, const at::Tensor& q, AngleReduction form);

// The "frame-norm" position loss for one decoder: mean over clips and frames
// of the Euclidean norm of the joint position error over all joints.
// p_hat, p: (B, T, J, 3) in the model's position unit (millimetres divided by
// one scale for all joints).
at::Tensor position_loss(const at::Tensor& p_hat, const at::Tensor& p);

// Eq. 10 as the paper writes it: each joint's Euclidean position error summed
// over the joints, the mean over clips and frames; same shapes and unit. A
// joint that never moves (the root, with the translation dropped) adds 0.
at::Tensor position_loss_joint_sum(const at::Tensor& p_hat, const at::Tensor& p);

// The reference implementation's position loss: the error of each
// coordinate divided by that coordinate's standard deviation over the
// training frames, and the mean over clips, frames and the joints in
// `counted_joints` of each joint's norm. p_hat, p: (B, T, J, 3) in mm;
// inverse_std: (J, 3), 1/std for a kept coordinate and 0 for a dropped one;
// counted_joints: (K) int64 indices of the joints with a kept coordinate.
at::Tensor position_loss_standardized(const at::Tensor& p_hat, const at::Tensor& p, const at::Tensor& inverse_std,
                                      const at::Tensor& counted_joints);

// Eq. 11 for one decoder: mean absolute difference between the codes z and
// z_hat = Enc(Dec(z)), both (B, latent).
at::Tensor manifold_loss(const at::Tensor& z_hat, const at::Tensor& z);

// Eq. 12: maximum mean discrepancy between encoded codes and prior samples,
// both (B, latent), with the inverse multiquadratic kernel
// k(x, y) = C / (C + |x - y|^2), C = 2 * latent * prior_variance; the
// unbiased estimator (diagonal terms left out). Zero in expectation when the
// two sets come from one distribution.
at::Tensor mmd_inverse_multiquadratic(const at::Tensor& codes, const at::Tensor& prior_samples, double prior_variance);

// The reference implementation's MMD: the estimator above summed over the
// kernel scales C x {0.1, 0.2, 0.5, 1, 2, 5, 10}, with the within-set sums
// keeping their diagonal (k(x, x) = 1: a constant 2 x 7 / (n - 1) above the
// unbiased value, with the same gradient).
at::Tensor mmd_inverse_multiquadratic_seven_scales(const at::Tensor& codes, const at::Tensor& prior_samples,
                                                   double prior_variance);

// Eq. 12 in the form `form` asks for.
at::Tensor mmd(const at::Tensor& codes, const at::Tensor& prior_samples, double prior_variance, MmdForm form);

// The "half-mean" least-squares discriminator loss (Eq. 13 with means for
// its sums, without lambda_G) on scores of real (B) and generated (B) motions.
at::Tensor lsgan_discriminator_loss(const at::Tensor& real_scores, const at::Tensor& fake_scores);

// The "half-mean" generator loss (Eq. 14 with a mean for its sum) on the
// scores of generated motions.
at::Tensor lsgan_generator_loss(const at::Tensor& fake_scores);

// Eq. 13 and 14 on the discriminator's per-step scores (B, steps) in the form
// `form` asks for: kHalfMean as above on each clip's mean score; kHalfSum,
// the paper's, one half of the sum over clips of the same; kBatchSum, the
// reference's, the sum over clips of the mean over steps of the squared
// error. `real_weight` multiplies the real clips' term (the reference takes
// one discriminator loss per decoder, each with the real clips).
at::Tensor lsgan_discriminator_loss(const at::Tensor& real_step_scores, const at::Tensor& fake_step_scores,
                                    AdversarialReduction form, double real_weight);
at::Tensor lsgan_generator_loss(const at::Tensor& fake_step_scores, AdversarialReduction form);

}  // namespace mm
