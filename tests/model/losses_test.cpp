#include "losses.h"

#include <gtest/gtest.h>

namespace mm {
namespace {

TEST(Losses, MmdIsNearZeroForSamplesOfOneDistribution) {
  at::manual_seed(3);
  auto a = at::randn({500, 64}), b = at::randn({500, 64});
  EXPECT_NEAR(mmd_inverse_multiquadratic(a, b, 1.0).item<float>(), 0.0f, 2e-3);
}

TEST(Losses, MmdGrowsWithTheShiftBetweenDistributions) {
  at::manual_seed(4);
  auto prior = at::randn({500, 64});
  const float same = mmd_inverse_multiquadratic(at::randn({500, 64}), prior, 1.0).item<float>();
  const float shifted = mmd_inverse_multiquadratic(at::randn({500, 64}) + 1.0, prior, 1.0).item<float>();
  const float far = mmd_inverse_multiquadratic(at::randn({500, 64}) * 3.0, prior, 1.0).item<float>();
  EXPECT_GT(shifted, 20 * std::abs(same) + 0.02f);
  EXPECT_GT(far, 20 * std::abs(same) + 0.02f);
}

TEST(Losses, AngleLossIsMeanPerFrameEuclideanNorm) {
  auto q = at::zeros({2, 3, 4});
  auto q_hat = q.clone();
  q_hat.select(2, 0).fill_(3.0);
  q_hat.select(2, 1).fill_(4.0);  // every frame off by a (3, 4, 0, 0) vector: norm 5
  EXPECT_NEAR(angle_loss(q_hat, q).item<float>(), 5.0f, 1e-5);
  EXPECT_NEAR(angle_loss(q, q).item<float>(), 0.0f, 1e-5);
}

TEST(Losses, PositionLossTakesTheNormOverAllJoints) {
  auto p = at::zeros({1, 2, 4, 3});
  auto p_hat = p.clone();
  p_hat.select(2, 0).select(2, 0).fill_(2.0);  // joint 0 off by 2 in x
  p_hat.select(2, 3).select(2, 1).fill_(2.0);  // joint 3 off by 2 in y
  EXPECT_NEAR(position_loss(p_hat, p).item<float>(), std::sqrt(8.0f), 1e-5);
}

TEST(Losses, PerfectReconstructionHasFiniteGradient) {
  auto q = at::randn({2, 5, 3});
  auto q_hat = q.clone().requires_grad_(true);
  angle_loss(q_hat, q).backward();
  EXPECT_TRUE(at::isfinite(q_hat.grad()).all().item<bool>());
}

TEST(Losses, LsganTargetsAreOneForRealAndZeroForGenerated) {
  auto ones = at::ones({8}), zeros = at::zeros({8});
  EXPECT_NEAR(lsgan_discriminator_loss(ones, zeros).item<float>(), 0.0f, 1e-6);
  EXPECT_NEAR(lsgan_discriminator_loss(zeros, ones).item<float>(), 1.0f, 1e-6);
  EXPECT_NEAR(lsgan_generator_loss(ones).item<float>(), 0.0f, 1e-6);
  EXPECT_NEAR(lsgan_generator_loss(zeros).item<float>(), 0.5f, 1e-6);
}

TEST(Losses, ManifoldLossIsMeanAbsoluteDifference) {
  auto z = at::zeros({2, 4});
  auto z_hat = at::full({2, 4}, -0.5);
  EXPECT_NEAR(manifold_loss(z_hat, z).item<float>(), 0.5f, 1e-6);
}

}  // namespace
}  // namespace mm
