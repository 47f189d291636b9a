#include "model/losses.h"

#include <gtest/gtest.h>

#include "format/input_error.h"

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

// The reference implementation's forms (training_config.h, LossForms).

TEST(ReferenceLosses, AngleTripletMeanAveragesTheTripletNorms) {
  auto q = at::zeros({1, 2, 6});
  auto q_hat = q.clone();
  q_hat[0][0][0] = 3.0;
  q_hat[0][0][1] = 4.0;  // frame 0: first triplet off by (3, 4, 0), norm 5; everything else exact
  // Mean over 2 frames x 2 triplets: 5 / 4.
  EXPECT_NEAR(angle_loss_triplet_mean(q_hat, q).item<float>(), 1.25f, 1e-5);
  EXPECT_NEAR(angle_loss(q_hat, q, AngleReduction::kTripletMean).item<float>(), 1.25f, 1e-5);
  // The frame-norm form on the same error: one norm per frame, mean over 2 frames.
  EXPECT_NEAR(angle_loss(q_hat, q, AngleReduction::kFrameNorm).item<float>(), 2.5f, 1e-5);
  EXPECT_THROW(angle_loss_triplet_mean(at::zeros({1, 1, 4}), at::zeros({1, 1, 4})), InputError);
}

TEST(ReferenceLosses, PositionLossStandardizesEachCoordinateAndSkipsDroppedJoints) {
  auto p = at::zeros({1, 1, 3, 3});
  auto p_hat = p.clone();
  p_hat[0][0][0][0] = 100.0;  // joint 0 is dropped: its error must not count
  p_hat[0][0][1][0] = 3.0;
  p_hat[0][0][1][1] = 8.0;  // joint 1: (3, 8, 0) mm over std (1, 2, 1) mm -> (3, 4, 0), norm 5
  auto inverse_std = at::tensor({0.0f, 0.0f, 0.0f, 1.0f, 0.5f, 1.0f, 1.0f, 1.0f, 1.0f}).reshape({3, 3});
  auto counted = at::tensor({int64_t{1}, int64_t{2}});
  // Joints 1 and 2 counted: (5 + 0) / 2.
  EXPECT_NEAR(position_loss_standardized(p_hat, p, inverse_std, counted).item<float>(), 2.5f, 1e-5);
}

TEST(ReferenceLosses, SevenScaleMmdKeepsTheDiagonalAndSumsTheScales) {
  // latent 1, sigma_z^2 1: C = 2 x scale. Codes {0, 1}, prior {0, 2}; per
  // scale (k(0) + k(1)) + (k(0) + k(4)) - (k(0) + k(4) + 2 k(1)) / 2 with
  // k(d^2) = C / (C + d^2), summed over the seven scales (computed by hand).
  auto codes = at::tensor({0.0f, 1.0f}).reshape({2, 1}), prior = at::tensor({0.0f, 2.0f}).reshape({2, 1});
  EXPECT_NEAR(mmd_inverse_multiquadratic_seven_scales(codes, prior, 1.0).item<float>(), 11.85974026f, 1e-5);
  EXPECT_NEAR(mmd(codes, prior, 1.0, MmdForm::kSevenScales).item<float>(), 11.85974026f, 1e-5);
}

TEST(ReferenceLosses, SevenScaleMmdDiffersFromTheUnbiasedSumOnlyByTheDiagonal) {
  at::manual_seed(5);
  auto codes = at::randn({30, 64}), prior = at::randn({30, 64});
  double unbiased = 0;
  for (double scale : {0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0}) {
    unbiased += mmd_inverse_multiquadratic(codes, prior, scale).item<double>();  // C scales with sigma_z^2
  }
  // Two within-set sums per scale, each n / (n (n - 1)) = 1/29 higher.
  EXPECT_NEAR(mmd_inverse_multiquadratic_seven_scales(codes, prior, 1.0).item<double>() - unbiased, 14.0 / 29.0, 1e-4);
}

TEST(ReferenceLosses, BatchSumLsganSumsClipsOfPerStepSquares) {
  auto fake = at::tensor({0.0f, 2.0f, 1.0f, 1.0f}).reshape({2, 2});  // clip means 1 and 1
  // Generator: clip 0 mean((0-1)^2, (2-1)^2) = 1, clip 1 0: sum 1. On the
  // clip means (the paper's form) the same scores are perfect.
  EXPECT_NEAR(lsgan_generator_loss(fake, AdversarialReduction::kBatchSum).item<float>(), 1.0f, 1e-6);
  EXPECT_NEAR(lsgan_generator_loss(fake, AdversarialReduction::kHalfMean).item<float>(), 0.0f, 1e-6);
  auto real = at::tensor({1.0f, 1.0f, 1.0f, 3.0f}).reshape({2, 2});
  // Discriminator: fake 2 + 1, real 0 + mean(0, 4) = 2 counted twice: 7.
  EXPECT_NEAR(lsgan_discriminator_loss(real, fake, AdversarialReduction::kBatchSum, 2.0).item<float>(), 7.0f, 1e-6);
  // Half-mean: 0.5 mean(1, 1) + 0.5 mean((1-1)^2, (2-1)^2) = 0.75.
  EXPECT_NEAR(lsgan_discriminator_loss(real, fake, AdversarialReduction::kHalfMean, 1.0).item<float>(), 0.75f, 1e-6);
}

// The paper's equations as written (the "paper" preset).

TEST(PaperLosses, AngleJointSumAddsTheJointNormsOfAFrame) {
  auto q = at::zeros({2, 2, 6});
  auto q_hat = q.clone();
  // Clip 0, frame 0: joint 0 off by (3, 4, 0) (norm 5), joint 1 by (0, 0, 2)
  // (norm 2): 7. Clip 1, frame 1: joint 1 off by (1, 2, 2) (norm 3). The
  // other two frames are exact. Sum over joints, mean over 4 frames: 10 / 4.
  q_hat[0][0][0] = 3.0;
  q_hat[0][0][1] = 4.0;
  q_hat[0][0][5] = 2.0;
  q_hat[1][1][3] = 1.0;
  q_hat[1][1][4] = 2.0;
  q_hat[1][1][5] = 2.0;
  EXPECT_NEAR(angle_loss_joint_sum(q_hat, q).item<float>(), 2.5f, 1e-5);
  EXPECT_NEAR(angle_loss(q_hat, q, AngleReduction::kJointSum).item<float>(), 2.5f, 1e-5);
  // It is the triplet mean times the joints per frame (2).
  EXPECT_NEAR(angle_loss_triplet_mean(q_hat, q).item<float>() * 2.0f, 2.5f, 1e-5);
  // One norm per frame instead: (sqrt(29) + 3) / 4.
  EXPECT_NEAR(angle_loss(q_hat, q, AngleReduction::kFrameNorm).item<float>(), (std::sqrt(29.0f) + 3.0f) / 4.0f, 1e-5);
  EXPECT_THROW(angle_loss_joint_sum(at::zeros({1, 1, 4}), at::zeros({1, 1, 4})), InputError);
}

TEST(PaperLosses, PositionJointSumAddsEachJointsDistance) {
  auto p = at::zeros({1, 2, 3, 3});
  auto p_hat = p.clone();
  p_hat[0][0][0][0] = 6.0;
  p_hat[0][0][0][1] = 8.0;  // frame 0, joint 0: (6, 8, 0), 10
  p_hat[0][0][2][2] = 1.0;  // frame 0, joint 2: (0, 0, 1), 1
  p_hat[0][1][1][1] = 4.0;  // frame 1, joint 1: (0, 4, 0), 4
  // Frame sums 11 and 4, mean over the 2 frames: 7.5.
  EXPECT_NEAR(position_loss_joint_sum(p_hat, p).item<float>(), 7.5f, 1e-5);
  // The frame-norm form: (sqrt(101) + 4) / 2.
  EXPECT_NEAR(position_loss(p_hat, p).item<float>(), (std::sqrt(101.0f) + 4.0f) / 2.0f, 1e-5);
}

TEST(PaperLosses, HalfSumLsganIsHalfTheSumOverClipsOfTheClipMeansSquaredError) {
  // Three clips of two discriminator steps; clip mean scores 0.5, 1 and 0.
  auto fake = at::tensor({0.0f, 1.0f, 1.0f, 1.0f, 0.0f, 0.0f}).reshape({3, 2});
  // Generator (target 1): 0.5 x ((0.5-1)^2 + 0 + 1) = 0.625; the half-mean is a third of it.
  EXPECT_NEAR(lsgan_generator_loss(fake, AdversarialReduction::kHalfSum).item<float>(), 0.625f, 1e-6);
  EXPECT_NEAR(lsgan_generator_loss(fake, AdversarialReduction::kHalfMean).item<float>(), 0.625f / 3.0f, 1e-6);
  // Discriminator: fake targets 0: 0.5 x (0.25 + 1 + 0) = 0.625; real clip
  // means 1 and 2 against 1: 0.5 x (0 + 1) = 0.5; total 1.125.
  auto real = at::tensor({1.0f, 1.0f, 1.0f, 3.0f}).reshape({2, 2});
  EXPECT_NEAR(lsgan_discriminator_loss(real, fake, AdversarialReduction::kHalfSum, 1.0).item<float>(), 1.125f, 1e-6);
}

}  // namespace
}  // namespace mm
