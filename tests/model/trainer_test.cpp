#include "model/trainer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "format/input_error.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

using test::small_h36m;
using test::tiny_config;

bool same_parameters(MotionManifold& a, MotionManifold& b) {
  auto pa = a.generator_parameters(), pb = b.generator_parameters();
  auto da = a.discriminator()->parameters(), db = b.discriminator()->parameters();
  pa.insert(pa.end(), da.begin(), da.end());
  pb.insert(pb.end(), db.begin(), db.end());
  if (pa.size() != pb.size()) return false;
  for (size_t i = 0; i < pa.size(); ++i) {
    if (!at::equal(pa[i], pb[i])) return false;
  }
  return true;
}

TEST(Trainer, EveryParameterReceivesGradient) {
  MM_REQUIRE_H36M();
  Trainer trainer(tiny_config("DKGM"), small_h36m(), at::kCPU);
  trainer.step();
  auto& model = trainer.model();
  for (auto* module : std::vector<torch::nn::Module*>{model.encoder().ptr().get(),
                                                      model.decoder(DecoderKind::kRotation).ptr().get(),
                                                      model.decoder(DecoderKind::kVelocity).ptr().get(),
                                                      model.discriminator().ptr().get()}) {
    for (const auto& p : module->named_parameters()) {
      ASSERT_TRUE(p.value().grad().defined()) << p.key();
      EXPECT_GT(p.value().grad().abs().sum().item<double>(), 0.0) << p.key();
    }
  }
}

TEST(Trainer, AllLossTermsOfTheFullModelAreReported) {
  MM_REQUIRE_H36M();
  Trainer trainer(tiny_config("DKGM"), small_h36m(), at::kCPU);
  const LossValues losses = trainer.step();
  for (const char* term : {"L_ang", "L_pos", "L_R", "L_M", "L_W", "L_G", "L_D", "total"}) {
    ASSERT_TRUE(losses.count(term)) << term;
    EXPECT_TRUE(std::isfinite(losses.at(term))) << term;
    EXPECT_GT(losses.at(term), 0.0) << term;
  }
  ASSERT_TRUE(losses.count("D_acc"));
  EXPECT_GE(losses.at("D_acc"), 0.0);
  EXPECT_LE(losses.at("D_acc"), 1.0);
}

TEST(Trainer, AblatedTermsStayZero) {
  MM_REQUIRE_H36M();
  Trainer trainer(tiny_config("S"), small_h36m(), at::kCPU);
  const LossValues losses = trainer.step();
  EXPECT_EQ(losses.at("L_pos"), 0.0);
  EXPECT_EQ(losses.at("L_G"), 0.0);
  EXPECT_EQ(losses.at("L_M"), 0.0);
  EXPECT_GT(losses.at("L_W"), 0.0);
  EXPECT_FALSE(trainer.model().has_decoder(DecoderKind::kVelocity));
}

// The first step's outputs are the same for every weight (same seed); only
// how the angle loss counts the root's rotation values differs.
TEST(Trainer, TheRootRotationWeightScalesTheAngleLossOnlyWhereTheRootTurns) {
  MM_REQUIRE_H36M();
  const auto first_angle_loss = [](double root_rotation) {
    TrainConfig config = tiny_config("DKGM");
    config.weights.root_rotation = root_rotation;
    Trainer trainer(config, small_h36m(), at::kCPU);
    return trainer.step().at("L_ang");
  };
  const double without = first_angle_loss(0.0), paper = first_angle_loss(1.0), heavier = first_angle_loss(4.0);
  EXPECT_EQ(paper, Trainer(tiny_config("DKGM"), small_h36m(), at::kCPU).step().at("L_ang"));
  EXPECT_LT(without, paper);
  EXPECT_GT(heavier, paper);
  // Three of the 51 values: the others still carry most of the loss.
  EXPECT_GT(without, 0.5 * paper);
}

TEST(Trainer, SameSeedGivesTheSameRun) {
  MM_REQUIRE_H36M();
  Trainer a(tiny_config(), small_h36m(), at::kCPU), b(tiny_config(), small_h36m(), at::kCPU);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(a.step(), b.step());
  EXPECT_TRUE(same_parameters(a.model(), b.model()));
}

// Six steps of `config` in one run, and three then three more from its
// checkpoint, end at the same parameters.
void expect_resumed_run_is_uninterrupted(TrainConfig config) {
  test::ScratchDir dir;
  config.iterations = 6;
  Trainer uninterrupted(config, small_h36m(), at::kCPU);
  for (int i = 0; i < 6; ++i) uninterrupted.step();

  Trainer first_half(config, small_h36m(), at::kCPU);
  for (int i = 0; i < 3; ++i) first_half.step();
  first_half.save_checkpoint(dir.file("checkpoint.pt"));
  auto resumed = Trainer::resume(dir.file("checkpoint.pt"), small_h36m(), at::kCPU);
  EXPECT_EQ(resumed->iteration(), 3);
  for (int i = 0; i < 3; ++i) resumed->step();
  EXPECT_TRUE(same_parameters(uninterrupted.model(), resumed->model()));
}

TEST(Trainer, ResumedRunMatchesUninterruptedRun) {
  MM_REQUIRE_H36M();
  expect_resumed_run_is_uninterrupted(tiny_config());
}

// Mirrored clips (TrainConfig::mirror) reach the step, and the coin that
// mirrors them is part of the sampler's state, so a resumed mirrored run is
// the uninterrupted one.
TEST(Trainer, AMirroredRunTrainsOnOtherClipsAndResumesAsItself) {
  MM_REQUIRE_H36M();
  TrainConfig config = tiny_config();
  config.mirror = true;
  EXPECT_NE(Trainer(config, small_h36m(), at::kCPU).step(), Trainer(tiny_config(), small_h36m(), at::kCPU).step());
  expect_resumed_run_is_uninterrupted(config);
}

TEST(Trainer, RunReportsProgressWritesLogAndCheckpoint) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  TrainConfig config = tiny_config();
  config.iterations = 4;
  config.log_every = 2;
  config.output_dir = dir.file("run");
  Trainer trainer(config, small_h36m(), at::kCPU);
  std::vector<TrainProgress> reports;
  EXPECT_EQ(trainer.run([&](const TrainProgress& p) { reports.push_back(p); }), TrainOutcome::kFinished);
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports.back().iteration, 4);
  EXPECT_EQ(reports.back().total, 4);
  EXPECT_GT(reports.back().iterations_per_second, 0.0);
  EXPECT_TRUE(std::filesystem::exists(dir.file("run/checkpoint.pt")));
  std::ifstream log(dir.file("run/train_log.csv"));
  std::string header, line;
  std::getline(log, header);
  EXPECT_EQ(header.rfind("iteration,learning_rate,L_ang", 0), 0u) << header;
  int rows = 0;
  while (std::getline(log, line)) ++rows;
  EXPECT_EQ(rows, 2);
}

TEST(Trainer, CancelStopsTheRunAndKeepsACheckpoint) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  TrainConfig config = tiny_config();
  config.iterations = 1000;
  config.output_dir = dir.file("run");
  Trainer trainer(config, small_h36m(), at::kCPU);
  std::atomic<bool> cancel{false};
  auto outcome = trainer.run([&](const TrainProgress& p) { cancel = p.iteration >= 2; }, &cancel);
  EXPECT_EQ(outcome, TrainOutcome::kCancelled);
  EXPECT_EQ(trainer.iteration(), 2);
  auto resumed = Trainer::resume(dir.file("run/checkpoint.pt"), small_h36m(), at::kCPU);
  EXPECT_EQ(resumed->iteration(), 2);
}

TEST(Trainer, ResumeRejectsAFileThatIsNotACheckpoint) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const auto path = dir.write("checkpoint.pt", "not a checkpoint");
  try {
    Trainer::resume(path, small_h36m(), at::kCPU);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(Trainer, StartFromAnExportedModelTakesItsWeightsAndSchedule) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  TrainConfig config = tiny_config();
  config.iterations = 60;
  config.decay_every = 2;
  Trainer first(config, small_h36m(), at::kCPU);
  for (int i = 0; i < 5; ++i) first.step();
  first.model().save(dir.file("model"));
  const MotionManifold exported = MotionManifold::load(dir.file("model"));

  config.seed = 2;  // a different initialisation, overwritten by start_from
  Trainer second(config, small_h36m(), at::kCPU);
  EXPECT_FALSE(same_parameters(first.model(), second.model()));
  second.start_from(exported, first.iteration());
  EXPECT_TRUE(same_parameters(first.model(), second.model()));
  EXPECT_EQ(second.iteration(), 5);
  EXPECT_DOUBLE_EQ(second.learning_rate(), first.learning_rate());
  EXPECT_LT(second.learning_rate(), config.learning_rate);
  second.step();
  EXPECT_EQ(second.iteration(), 6);
}

TEST(Trainer, StartFromRejectsAModelOfAnotherShape) {
  MM_REQUIRE_H36M();
  TrainConfig config = tiny_config();
  Trainer trainer(config, small_h36m(), at::kCPU);
  TrainConfig other = config;
  other.model.hidden = config.model.hidden * 2;
  Trainer wider(other, small_h36m(), at::kCPU);
  try {
    trainer.start_from(wider.model(), 0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("model.hidden"), std::string::npos) << e.what();
  }
}

TEST(Trainer, ShortTrainingOnRealClipsHalvesReconstructionLoss) {
  MM_REQUIRE_H36M();
  // A handful of real clips: three S1 sequences.
  PreparedDataset few = small_h36m();
  few.sequences.resize(3);
  TrainConfig config = tiny_config("DKGM");
  config.model.hidden = 64;
  config.batch = 8;
  config.learning_rate = 2e-3;
  Trainer trainer(config, few, at::kCPU);
  auto mean_reconstruction = [&](int steps) {
    double sum = 0;
    for (int i = 0; i < steps; ++i) sum += trainer.step().at("L_R");
    return sum / steps;
  };
  const double start = mean_reconstruction(5);
  for (int i = 0; i < 250; ++i) trainer.step();
  const double end = mean_reconstruction(5);
  EXPECT_LT(end, 0.5 * start) << "L_R went from " << start << " to " << end;
}

TEST(Trainer, ReferenceLossFormsReachTheStep) {
  MM_REQUIRE_H36M();
  // Same seed: the first step decodes the same clips with the same untrained
  // networks, and the discriminator is scored before its update, so the
  // forms' values stand in known relations (Cauchy-Schwarz and Jensen).
  TrainConfig frame_norm = tiny_config("DKGM"), reference = tiny_config("DKGM");
  reference.losses = loss_preset("reference", "losses");
  Trainer a(frame_norm, small_h36m(), at::kCPU), b(reference, small_h36m(), at::kCPU);
  const LossValues p = a.step(), r = b.step();
  for (const auto& [term, value] : r) EXPECT_TRUE(std::isfinite(value)) << term;
  // Two decoders; each triplet mean is at most its frame norm / sqrt(17).
  EXPECT_GT(r.at("L_ang"), 0.0);
  EXPECT_LE(r.at("L_ang"), p.at("L_ang") / std::sqrt(17.0) * (1 + 1e-5));
  // Batch sum of per-step squares >= 2 x batch x half-mean of clip means,
  // with the real clips counted once per decoder: >= 4 x batch x L_D.
  EXPECT_GE(r.at("L_D"), 4.0 * reference.batch * p.at("L_D") * (1 - 1e-5));
  EXPECT_GT(r.at("L_pos"), 0.0);
  EXPECT_NE(r.at("L_pos"), p.at("L_pos"));
}

TEST(Trainer, PaperLossFormsReachTheStep) {
  MM_REQUIRE_H36M();
  // Same seed and first step as above: the same decoded clips and scores.
  TrainConfig frame_norm = tiny_config("DKGM"), paper = tiny_config("DKGM");
  paper.losses = loss_preset("paper", "losses");
  Trainer a(frame_norm, small_h36m(), at::kCPU), b(paper, small_h36m(), at::kCPU);
  const LossValues f = a.step(), p = b.step();
  for (const auto& [term, value] : p) EXPECT_TRUE(std::isfinite(value)) << term;
  // A sum of the joints' norms is at least the norm of all of them and at
  // most sqrt(joints) times it (17 modelled joints; 32 joint positions).
  EXPECT_GE(p.at("L_ang"), f.at("L_ang") * (1 - 1e-5));
  EXPECT_LE(p.at("L_ang"), f.at("L_ang") * std::sqrt(17.0) * (1 + 1e-5));
  EXPECT_GE(p.at("L_pos"), f.at("L_pos") * (1 - 1e-5));
  EXPECT_LE(p.at("L_pos"), f.at("L_pos") * std::sqrt(32.0) * (1 + 1e-5));
  // Sums instead of means over the clips: the generated clips (two decoders'
  // worth) are 2 x batch, the real ones batch.
  EXPECT_GE(p.at("L_D"), paper.batch * f.at("L_D") * (1 - 1e-5));
  EXPECT_LE(p.at("L_D"), 2.0 * paper.batch * f.at("L_D") * (1 + 1e-5));
}

TEST(PositionScale, IsAFewHundredMillimetresForH36m) {
  MM_REQUIRE_H36M();
  const double scale = small_h36m().normalization.position_scale_mm;
  EXPECT_GT(scale, 100.0);
  EXPECT_LT(scale, 1000.0);
}

}  // namespace
}  // namespace mm
