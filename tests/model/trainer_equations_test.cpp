// A training step computes Eq. 8-16 on the batch it draws, clips the
// generator's gradient to the configured global norm and steps Adam at the
// scheduled rate. Each is checked against a replica: a second trainer with
// the same seed holds the networks as they were before the step, and a
// sampler with the same seed draws the same batch.
#include <ATen/CPUGeneratorImpl.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "model/clip_sampler.h"
#include "model/losses.h"
#include "model/trainer.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

using test::small_h36m;
using test::tiny_config;

// Weights far from the paper's and from each other, so that a term with the
// wrong weight, or a missing term, changes the total by far more than float
// rounding (see the test).
TrainConfig distinct_weights_config() {
  TrainConfig config = tiny_config("DKGM");
  config.weights.position = 2.5;
  config.weights.manifold = 0.7;
  config.weights.wasserstein = 3.0;
  config.weights.adversarial = 0.4;
  config.weights.prior_variance = 0.5;
  return config;
}

double relative_difference(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-12); }

TEST(TrainerEquations, LoggedTermsAreTheLossesOfSec33OnTheDrawnBatch) {
  MM_REQUIRE_H36M();
  const TrainConfig config = distinct_weights_config();
  const auto& data = small_h36m();
  Trainer trainer(config, data, at::kCPU);
  Trainer before(config, data, at::kCPU);  // same seed: the networks the step starts from
  ClipSampler sampler(data.subset(data.train_subjects), config.model.frames, config.seed);
  const auto motion = sampler.sample(config.batch);
  const LossValues logged = trainer.step();

  // The replica, through the stepwise reference paths and plain tensor
  // expressions (not the functions of losses.cpp for Eq. 9-11, 13-14).
  torch::NoGradGuard no_grad;
  auto& model = before.model();
  const auto code = model.encoder()->forward_reference(motion);
  const std::vector<at::Tensor> decoded{model.decoder(DecoderKind::kRotation)->forward_stepwise(code),
                                        model.decoder(DecoderKind::kVelocity)->forward_stepwise(code)};
  const auto truth_positions = model.positions_scaled(motion);
  double angle = 0, position = 0, manifold = 0;
  for (const auto& q_hat : decoded) {
    angle += (q_hat - motion).norm(2, -1).mean().item<double>();                                              // Eq. 9
    position += (model.positions_scaled(q_hat) - truth_positions).flatten(2).norm(2, -1).mean().item<double>();  // Eq. 10
    manifold += (model.encoder()->forward_reference(q_hat) - code).abs().mean().item<double>();               // Eq. 11
  }
  // Eq. 12 on the prior draw the trainer makes: its own generator, seeded seed + 1.
  auto prior_generator = at::detail::createCPUGenerator(config.seed + 1);
  const auto prior = at::randn({config.batch, config.model.latent}, prior_generator) *
                     std::sqrt(config.weights.prior_variance);
  const double wasserstein = mmd_inverse_multiquadratic(code, prior, config.weights.prior_variance).item<double>();
  // Eq. 13 with the discriminator before its update; Eq. 14 with it after
  // (the trainer updates the discriminator first), on both decoders' clips.
  const auto fake = at::cat(decoded, 0);
  const auto real_scores = model.discriminator()->forward(motion);
  const auto fake_scores = model.discriminator()->forward(fake);
  const double discriminator =
      (0.5 * fake_scores.pow(2).mean() + 0.5 * (real_scores - 1).pow(2).mean()).item<double>();
  const double accuracy = ((real_scores > 0.5).sum() + (fake_scores < 0.5).sum()).item<double>() /
                          static_cast<double>(real_scores.size(0) + fake_scores.size(0));
  const double adversarial =
      2 * (0.5 * (trainer.model().discriminator()->forward(fake) - 1).pow(2).mean()).item<double>();

  // The replica runs other code paths in float32 (stepwise GRU cells,
  // separate FK calls): agreement to 1e-4 relative. Dropping one decoder
  // from a term halves it; the wrong prior draw or variance moves L_W by
  // tens of percent.
  EXPECT_LT(relative_difference(logged.at("L_ang"), angle), 1e-4) << logged.at("L_ang") << " vs " << angle;
  EXPECT_LT(relative_difference(logged.at("L_pos"), position), 1e-4) << logged.at("L_pos") << " vs " << position;
  EXPECT_LT(relative_difference(logged.at("L_M"), manifold), 1e-4) << logged.at("L_M") << " vs " << manifold;
  EXPECT_LT(relative_difference(logged.at("L_W"), wasserstein), 1e-3) << logged.at("L_W") << " vs " << wasserstein;
  EXPECT_LT(relative_difference(logged.at("L_D"), discriminator), 1e-4) << logged.at("L_D") << " vs " << discriminator;
  EXPECT_LT(relative_difference(logged.at("L_G"), adversarial), 1e-4) << logged.at("L_G") << " vs " << adversarial;
  EXPECT_NEAR(logged.at("D_acc"), accuracy, 1e-6);  // float32 ratio of counts
}

TEST(TrainerEquations, TotalIsTheSumOfTheTermsWeightedByTheConfiguration) {
  MM_REQUIRE_H36M();
  const TrainConfig config = distinct_weights_config();
  Trainer trainer(config, small_h36m(), at::kCPU);
  for (int i = 0; i < 3; ++i) {
    const LossValues l = trainer.step();
    const auto& w = config.weights;
    const double reconstruction = l.at("L_ang") + w.position * l.at("L_pos");  // Eq. 8
    const double total = reconstruction + w.manifold * l.at("L_M") + w.wasserstein * l.at("L_W") +
                         w.adversarial * l.at("L_G");  // Eq. 15
    // The trainer sums in float32: 1e-6 relative. Every weighted term is
    // more than 1e-3 of the total here (checked below), so a missing term or
    // one weight in place of another is at least a thousand times further off.
    EXPECT_LT(relative_difference(l.at("L_R"), reconstruction), 1e-6) << l.at("L_R") << " vs " << reconstruction;
    EXPECT_LT(relative_difference(l.at("total"), total), 1e-6) << l.at("total") << " vs " << total;
    for (double term : {l.at("L_ang"), w.position * l.at("L_pos"), w.manifold * l.at("L_M"),
                        w.wasserstein * l.at("L_W"), w.adversarial * l.at("L_G")}) {
      EXPECT_GT(std::abs(term), 1e-3 * total) << "a term too small to tell its weight: " << term;
    }
  }
}

std::vector<at::Tensor> gradients_of(const std::vector<at::Tensor>& parameters) {
  std::vector<at::Tensor> out;
  for (const auto& p : parameters) out.push_back(p.grad().detach().clone().to(at::kDouble));
  return out;
}

std::vector<at::Tensor> values_of(const std::vector<at::Tensor>& parameters) {
  std::vector<at::Tensor> out;
  for (const auto& p : parameters) out.push_back(p.detach().clone().to(at::kDouble));
  return out;
}

double global_norm(const std::vector<at::Tensor>& tensors) {
  double squared = 0;
  for (const auto& t : tensors) squared += t.pow(2).sum().item<double>();
  return std::sqrt(squared);
}

TEST(TrainerEquations, GeneratorGradientIsScaledDownToTheConfiguredGlobalNorm) {
  MM_REQUIRE_H36M();
  TrainConfig unclipped_config = tiny_config("DKGM");
  unclipped_config.clip_norm = 0;  // off
  TrainConfig clipped_config = unclipped_config;
  clipped_config.clip_norm = 0.37;
  Trainer unclipped(unclipped_config, small_h36m(), at::kCPU), clipped(clipped_config, small_h36m(), at::kCPU);
  unclipped.step();
  clipped.step();
  const auto raw = gradients_of(unclipped.model().generator_parameters());
  const auto scaled = gradients_of(clipped.model().generator_parameters());
  const double raw_norm = global_norm(raw);
  ASSERT_GT(raw_norm, 2 * clipped_config.clip_norm) << "the test needs a gradient that gets clipped";
  // The global norm is exactly the configured one (the 1e-6 guard against a
  // zero norm changes it by < 1e-5 relative); clipping each tensor on its
  // own, or to the default 1.0, misses by far more.
  EXPECT_NEAR(global_norm(scaled), clipped_config.clip_norm, 1e-5);
  // One factor for all tensors: the direction is kept.
  const double factor = clipped_config.clip_norm / raw_norm;
  for (size_t i = 0; i < raw.size(); ++i) {
    EXPECT_TRUE(at::allclose(scaled[i], raw[i] * factor, 1e-4, 1e-9)) << "parameter tensor " << i;
  }
  // The discriminator's gradient is not the generator's and is left alone.
  const auto raw_d = gradients_of(unclipped.model().discriminator()->parameters());
  const auto scaled_d = gradients_of(clipped.model().discriminator()->parameters());
  for (size_t i = 0; i < raw_d.size(); ++i) EXPECT_TRUE(at::allclose(scaled_d[i], raw_d[i], 1e-6, 1e-12)) << i;
}

// Adam as torch::optim::Adam computes it (betas 0.9, 0.999, eps 1e-8, no
// weight decay), from the gradients each step left on the parameters.
struct AdamReplica {
  std::vector<at::Tensor> first, second;
  int step = 0;

  std::vector<at::Tensor> update(const std::vector<at::Tensor>& gradients, double learning_rate) {
    if (first.empty()) {
      for (const auto& g : gradients) {
        first.push_back(at::zeros_like(g));
        second.push_back(at::zeros_like(g));
      }
    }
    ++step;
    const double correction1 = 1 - std::pow(0.9, step), correction2 = 1 - std::pow(0.999, step);
    std::vector<at::Tensor> deltas;
    for (size_t i = 0; i < gradients.size(); ++i) {
      first[i] = 0.9 * first[i] + 0.1 * gradients[i];
      second[i] = 0.999 * second[i] + 0.001 * gradients[i].pow(2);
      deltas.push_back(-learning_rate / correction1 * first[i] / (second[i].sqrt() / std::sqrt(correction2) + 1e-8));
    }
    return deltas;
  }
};

TEST(TrainerEquations, GeneratorStepsAreAdamOnTheClippedGradientAtTheScheduledRate) {
  MM_REQUIRE_H36M();
  // The paper's schedule (training_config.h): 1e-3, times 0.999 every 20
  // iterations. Starting at iteration 39 the two steps run at 1e-3 * 0.999
  // and 1e-3 * 0.999^2; the clip is low enough to act on both steps.
  TrainConfig config = tiny_config("DKGM");
  config.iterations = 100;
  config.clip_norm = 0.37;
  EXPECT_DOUBLE_EQ(config.learning_rate, 1e-3);
  EXPECT_DOUBLE_EQ(config.lr_decay, 0.999);
  EXPECT_EQ(config.decay_every, 20);
  Trainer source(config, small_h36m(), at::kCPU);
  Trainer trainer(config, small_h36m(), at::kCPU);
  trainer.start_from(source.model(), 39);  // fresh Adam state at iteration 39

  const auto parameters = trainer.model().generator_parameters();
  AdamReplica adam;
  for (int step = 0; step < 2; ++step) {
    const double rate = 1e-3 * std::pow(0.999, step == 0 ? 1 : 2);
    EXPECT_DOUBLE_EQ(trainer.learning_rate(), rate);
    const auto before = values_of(parameters);
    trainer.step();
    const auto gradients = gradients_of(parameters);
    EXPECT_NEAR(global_norm(gradients), config.clip_norm, 1e-5) << "step " << step;
    const auto expected = adam.update(gradients, rate);
    const auto after = values_of(parameters);
    for (size_t i = 0; i < parameters.size(); ++i) {
      // Updates are about 1e-3 per weight. 1e-4 relative covers Adam's
      // float32 arithmetic; 2e-8 the rounding of weights near 0.1 to float.
      // A rate off by one decay step (0.1%), Adam fed the unclipped gradient
      // (the second step's direction changes with the ratio of the two
      // steps' clip factors) or no bias correction fail it.
      EXPECT_TRUE(at::allclose(after[i] - before[i], expected[i], 1e-4, 2e-8))
          << "step " << step << ", parameter tensor " << i << ": max difference "
          << (after[i] - before[i] - expected[i]).abs().max().item<double>();
    }
  }
}

TEST(TrainerEquations, DiscriminatorStepsAtTheScheduledRate) {
  MM_REQUIRE_H36M();
  // A fresh Adam's first step moves each weight by the rate times
  // g / (|g| + 1e-8), which is the rate itself wherever |g| >> 1e-8, so the
  // median move of the discriminator's weights is the rate it was stepped at.
  // Iteration 40 of a schedule decaying by half every 20 iterations: 1e-3 / 4
  // (off by one decay step is a factor of 2, hence 1% is tolerance enough).
  // The adversarial weight is raised so that the gradients dwarf Adam's 1e-8.
  TrainConfig config = tiny_config("DKGM");
  config.iterations = 100;
  config.lr_decay = 0.5;
  config.weights.adversarial = 1.0;
  Trainer source(config, small_h36m(), at::kCPU);
  for (int64_t start : {int64_t{0}, int64_t{40}}) {
    Trainer trainer(config, small_h36m(), at::kCPU);
    trainer.start_from(source.model(), start);
    const auto parameters = trainer.model().discriminator()->parameters();
    const auto before = values_of(parameters);
    trainer.step();
    const auto after = values_of(parameters);
    std::vector<at::Tensor> moves;
    for (size_t i = 0; i < parameters.size(); ++i) moves.push_back((after[i] - before[i]).abs().flatten());
    const double median = at::cat(moves).median().item<double>();
    const double rate = 1e-3 * std::pow(0.5, start / 20);
    EXPECT_LT(relative_difference(median, rate), 1e-2) << "iteration " << start << ": median move " << median;
  }
}

}  // namespace
}  // namespace mm
