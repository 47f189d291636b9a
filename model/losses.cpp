#include "model/losses.h"

#include <string>

#include "format/input_error.h"

namespace mm {
namespace {

// sqrt has an infinite derivative at 0; a perfect frame must not produce NaN.
constexpr double kNormEpsilon = 1e-12;

at::Tensor mean_norm_over_last(const at::Tensor& difference, int64_t dims_to_flatten) {
  auto flat = difference.flatten(difference.dim() - dims_to_flatten, -1);
  return (flat.pow(2).sum(-1) + kNormEpsilon).sqrt().mean();
}

// The norm of each group of the last `dims_to_flatten` dimensions, summed
// over the groups of dimension -2 (the joints), averaged over the rest.
at::Tensor joint_norm_sum(const at::Tensor& per_joint_difference) {
  return (per_joint_difference.pow(2).sum(-1) + kNormEpsilon).sqrt().sum(-1).mean();
}

// (..., D) -> (..., D/3, 3): the pose values as the joints' triplets.
at::Tensor as_triplets(const at::Tensor& values) {
  const int64_t count = values.size(-1);
  if (count % 3 != 0) {
    throw InputError("q", "expected a multiple of 3 values per frame (triplets), found " + std::to_string(count));
  }
  auto sizes = values.sizes().vec();
  sizes.back() = count / 3;
  sizes.push_back(3);
  return values.reshape(sizes);
}

at::Tensor imq_kernel(const at::Tensor& x, const at::Tensor& y, double c) {
  auto squared_distance = (x.unsqueeze(1) - y.unsqueeze(0)).pow(2).sum(-1);
  return c / (c + squared_distance);
}

}  // namespace

at::Tensor angle_loss(const at::Tensor& q_hat, const at::Tensor& q) { return mean_norm_over_last(q_hat - q, 1); }

at::Tensor angle_loss_triplet_mean(const at::Tensor& q_hat, const at::Tensor& q) {
  return mean_norm_over_last(as_triplets(q_hat - q), 1);
}

at::Tensor angle_loss_joint_sum(const at::Tensor& q_hat, const at::Tensor& q) {
  return joint_norm_sum(as_triplets(q_hat - q));
}

at::Tensor angle_loss(const at::Tensor& q_hat, const at::Tensor& q, AngleReduction form) {
  switch (form) {
    case AngleReduction::kTripletMean:
      return angle_loss_triplet_mean(q_hat, q);
    case AngleReduction::kJointSum:
      return angle_loss_joint_sum(q_hat, q);
    case AngleReduction::kFrameNorm:
      break;
  }
  return angle_loss(q_hat, q);
}

at::Tensor position_loss(const at::Tensor& p_hat, const at::Tensor& p) { return mean_norm_over_last(p_hat - p, 2); }

at::Tensor position_loss_joint_sum(const at::Tensor& p_hat, const at::Tensor& p) { return joint_norm_sum(p_hat - p); }

at::Tensor position_loss_standardized(const at::Tensor& p_hat, const at::Tensor& p, const at::Tensor& inverse_std,
                                      const at::Tensor& counted_joints) {
  // The mean cancels in the difference of two standardised positions.
  const auto standardized = (p_hat - p) * inverse_std;
  return mean_norm_over_last(standardized.index_select(-2, counted_joints), 1);
}

at::Tensor manifold_loss(const at::Tensor& z_hat, const at::Tensor& z) { return (z_hat - z).abs().mean(); }

at::Tensor mmd_inverse_multiquadratic(const at::Tensor& codes, const at::Tensor& prior_samples, double prior_variance) {
  const int64_t n = codes.size(0);
  const double c = 2.0 * static_cast<double>(codes.size(1)) * prior_variance;
  const double pairs = static_cast<double>(n) * static_cast<double>(n - 1);
  // k(x, x) = 1, so each within-set sum drops exactly n from its diagonal.
  auto within_codes = (imq_kernel(codes, codes, c).sum() - static_cast<double>(n)) / pairs;
  auto within_prior = (imq_kernel(prior_samples, prior_samples, c).sum() - static_cast<double>(n)) / pairs;
  auto across = imq_kernel(codes, prior_samples, c).mean();
  return within_codes + within_prior - 2.0 * across;
}

at::Tensor mmd_inverse_multiquadratic_seven_scales(const at::Tensor& codes, const at::Tensor& prior_samples,
                                                   double prior_variance) {
  const int64_t n = codes.size(0);
  const double base = 2.0 * static_cast<double>(codes.size(1)) * prior_variance;
  const double pairs = static_cast<double>(n) * static_cast<double>(n - 1);
  auto total = at::zeros({}, codes.options());
  for (double scale : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0}) {
    const double c = base * scale;
    total = total + imq_kernel(codes, codes, c).sum() / pairs + imq_kernel(prior_samples, prior_samples, c).sum() / pairs -
            2.0 * imq_kernel(codes, prior_samples, c).mean();
  }
  return total;
}

at::Tensor mmd(const at::Tensor& codes, const at::Tensor& prior_samples, double prior_variance, MmdForm form) {
  return form == MmdForm::kSevenScales ? mmd_inverse_multiquadratic_seven_scales(codes, prior_samples, prior_variance)
                                       : mmd_inverse_multiquadratic(codes, prior_samples, prior_variance);
}

at::Tensor lsgan_discriminator_loss(const at::Tensor& real_step_scores, const at::Tensor& fake_step_scores,
                                    AdversarialReduction form, double real_weight) {
  switch (form) {
    case AdversarialReduction::kHalfMean:
      return 0.5 * fake_step_scores.mean(1).pow(2).mean() +
             real_weight * 0.5 * (real_step_scores.mean(1) - 1.0).pow(2).mean();
    case AdversarialReduction::kHalfSum:
      return 0.5 * fake_step_scores.mean(1).pow(2).sum() +
             real_weight * 0.5 * (real_step_scores.mean(1) - 1.0).pow(2).sum();
    case AdversarialReduction::kBatchSum:
      break;
  }
  return fake_step_scores.pow(2).mean(1).sum() + real_weight * (real_step_scores - 1.0).pow(2).mean(1).sum();
}

at::Tensor lsgan_generator_loss(const at::Tensor& fake_step_scores, AdversarialReduction form) {
  switch (form) {
    case AdversarialReduction::kHalfMean:
      return lsgan_generator_loss(fake_step_scores.mean(1));
    case AdversarialReduction::kHalfSum:
      return 0.5 * (fake_step_scores.mean(1) - 1.0).pow(2).sum();
    case AdversarialReduction::kBatchSum:
      break;
  }
  return (fake_step_scores - 1.0).pow(2).mean(1).sum();
}

at::Tensor lsgan_discriminator_loss(const at::Tensor& real_scores, const at::Tensor& fake_scores) {
  return 0.5 * fake_scores.pow(2).mean() + 0.5 * (real_scores - 1.0).pow(2).mean();
}

at::Tensor lsgan_generator_loss(const at::Tensor& fake_scores) { return 0.5 * (fake_scores - 1.0).pow(2).mean(); }

}  // namespace mm
