// Evaluation (Table 1) and the latent operations of Sec. 5 on a briefly
// trained tiny model and real S5 clips.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "format/input_error.h"
#include "format/motion_text.h"
#include "model/evaluation.h"
#include "model/latent_operations.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

using test::small_h36m;

MotionManifold& trained_tiny_model() {
  static std::unique_ptr<Trainer> trainer = [] {
    auto t = std::make_unique<Trainer>(test::tiny_config(), small_h36m(), at::kCPU);
    for (int i = 0; i < 30; ++i) t->step();
    t->model().train(false);
    return t;
  }();
  return trainer->model();
}

// A real S5 clip as raw frames of the model's length.
MotionFrames s5_clip(int index, int frames) {
  const auto test_sequences = small_h36m().subset(small_h36m().test_subjects);
  const auto& s = *test_sequences.at(index);
  MotionFrames normalized;
  normalized.columns = s.normalized.columns;
  normalized.values.assign(s.normalized.frame(0), s.normalized.frame(0) + frames * s.normalized.columns);
  return small_h36m().normalization.denormalize(normalized);
}

TEST(Evaluation, ReportsEveryIntervalForBothDecoders) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto test_sequences = small_h36m().subset(small_h36m().test_subjects);
  const auto report = nlohmann::json::parse(evaluate_reconstruction(model, test_sequences, EvaluationOptions{}));
  EXPECT_EQ(report["clips"], 30);
  EXPECT_EQ(report["test_clips"].size(), 30u);
  for (const char* decoder : {"rotation", "velocity"}) {
    const auto& d = report["decoders"][decoder];
    for (const char* metric : {"E_r", "E_p", "mpjpe_mm", "angle_error_rad"}) {
      ASSERT_EQ(d[metric].size(), 5u) << decoder << " " << metric;
      for (double v : d[metric]) EXPECT_TRUE(std::isfinite(v) && v > 0) << decoder << " " << metric;
    }
    EXPECT_GT(d["E_z"].get<double>(), 0.0);
  }
  // Denoising: both corruptions drop the same half of the values, and each
  // finds its dropped values (at the mean, at zero) as missing; once known,
  // what they were set to no longer matters to the fill.
  const auto& corruptions = report["denoising"]["corruptions"];
  ASSERT_EQ(corruptions.size(), 4u);
  const auto& reference = corruptions[0];
  const auto& zeroed = corruptions[1];
  EXPECT_EQ(reference["corruption"], "reference");
  EXPECT_EQ(zeroed["corruption"], "zeroed");
  EXPECT_NEAR(reference["missing_fraction"].get<double>(), 0.5, 0.01);
  EXPECT_NEAR(reference["missing_fraction"].get<double>(), zeroed["missing_fraction"].get<double>(), 1e-3);
  EXPECT_NEAR(reference["denoised_missing_mpjpe_mm"].get<double>(), zeroed["denoised_missing_mpjpe_mm"].get<double>(),
              0.5);
  EXPECT_LT(reference["corrupted_mpjpe_mm"].get<double>(), zeroed["corrupted_mpjpe_mm"].get<double>());
}

TEST(Evaluation, SeedSpreadIsTheMeanAndSampleStdOfTheSeedsEvaluations) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto test_sequences = small_h36m().subset(small_h36m().test_subjects);
  EvaluationOptions options;
  options.clips = 4;
  options.seed = 5;
  options.corruption_probability = 0;
  std::vector<double> values;  // rotation decoder, E_r at 2.4 s, for seeds 5, 6, 7
  for (uint64_t seed : {5, 6, 7}) {
    options.seed = seed;
    values.push_back(nlohmann::json::parse(evaluate_reconstruction(model, test_sequences, options))["decoders"]
                         ["rotation"]["E_r"][1]
                             .get<double>());
  }
  options.seed = 5;
  options.spread_seeds = 3;
  const auto spread = nlohmann::json::parse(evaluate_reconstruction(model, test_sequences, options))["seed_spread"];
  EXPECT_EQ(spread["seeds"], nlohmann::json({5, 6, 7}));
  const double mean = (values[0] + values[1] + values[2]) / 3;
  double squares = 0;
  for (double v : values) squares += (v - mean) * (v - mean);
  const auto& e_r = spread["decoders"]["rotation"]["E_r"];
  EXPECT_NEAR(e_r["mean"][1].get<double>(), mean, 1e-9);
  EXPECT_NEAR(e_r["std"][1].get<double>(), std::sqrt(squares / 2), 1e-9);  // sample std: n - 1 = 2
  ASSERT_GT(squares, 0.0);
}

TEST(Evaluation, SameSeedSelectsTheSameClips) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto test_sequences = small_h36m().subset(small_h36m().test_subjects);
  EXPECT_EQ(evaluate_reconstruction(model, test_sequences, EvaluationOptions{}),
            evaluate_reconstruction(model, test_sequences, EvaluationOptions{}));
  EvaluationOptions other;
  other.seed = 1;
  EXPECT_NE(evaluate_reconstruction(model, test_sequences, EvaluationOptions{}),
            evaluate_reconstruction(model, test_sequences, other));
}

TEST(LatentOperations, DecodedMotionsComeBackInTheInputFormat) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  auto code = encode_motions(model, {s5_clip(0, 30)});
  ASSERT_EQ(code.sizes(), (std::vector<int64_t>{1, 8}));
  auto decoded = decode_codes(model, code, DecoderKind::kRotation);
  ASSERT_EQ(decoded.size(), 1u);
  EXPECT_EQ(decoded[0].columns, 99);
  EXPECT_EQ(decoded[0].frame_count(), 30);
}

TEST(LatentOperations, WrongFrameCountNamesTheMotionAndTheExpectedLength) {
  MM_REQUIRE_H36M();
  try {
    encode_motions(trained_tiny_model(), {s5_clip(0, 30), s5_clip(1, 20)});
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("motions[1]: expected 30 frames"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("found 20"), std::string::npos) << e.what();
  }
}

TEST(LatentOperations, SamplingIsReproducibleBySeed) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  EXPECT_TRUE(at::equal(sample_codes(model, 4, 9), sample_codes(model, 4, 9)));
  EXPECT_FALSE(at::equal(sample_codes(model, 4, 9), sample_codes(model, 4, 10)));
  EXPECT_EQ(decode_codes(model, sample_codes(model, 3, 1), DecoderKind::kVelocity).size(), 3u);
}

TEST(LatentOperations, InterpolationRunsFromTheFirstCodeToTheSecond) {
  auto a = at::randn({8}), b = at::randn({8});
  for (bool spherical : {false, true}) {
    auto path = interpolate_codes(a, b, 5, spherical);
    ASSERT_EQ(path.sizes(), (std::vector<int64_t>{5, 8}));
    EXPECT_TRUE(at::allclose(path[0], a, 1e-5, 1e-5));
    EXPECT_TRUE(at::allclose(path[4], b, 1e-5, 1e-5));
  }
  EXPECT_TRUE(at::allclose(interpolate_codes(a, b, 3, false)[1], (a + b) / 2));
  EXPECT_THROW(interpolate_codes(a, b, 1, false), InputError);
  EXPECT_THROW(interpolate_codes(a, at::randn({7}), 3, false), InputError);
}

TEST(LatentOperations, SphericalInterpolationFollowsTheArcBetweenTheCodes) {
  // a = (2, 0) and b = (0, 4), a quarter turn apart. At t the direction is
  // (sin((1 - t) pi/2), sin(t pi/2)) (sin(pi/2) = 1) and the norm 2 (1 - t) + 4 t.
  const auto a = at::tensor({2.0f, 0.0f}), b = at::tensor({0.0f, 4.0f});
  const auto path = interpolate_codes(a, b, 5, true);
  const float r = 1.0f / std::sqrt(2.0f);
  // t = 1/4: (sin(3 pi/8), sin(pi/8)) x 2.5; t = 1/2: (r, r) x 3.
  EXPECT_TRUE(at::allclose(path[1], at::tensor({0.9238795f * 2.5f, 0.3826834f * 2.5f}), 1e-5, 1e-5)) << path[1];
  EXPECT_TRUE(at::allclose(path[2], at::tensor({3.0f * r, 3.0f * r}), 1e-5, 1e-5)) << path[2];
  // The line's midpoint, (1, 2), is 1.13 away from the arc's.
  EXPECT_FALSE(at::allclose(path[2], interpolate_codes(a, b, 5, false)[2], 1e-2, 1e-2));
}

TEST(LatentOperations, SphericalInterpolationFromTheZeroCodeIsTheLine) {
  // The origin has no direction, so there is no arc: the path is the line,
  // finite throughout.
  auto zero = at::zeros({8}), b = at::randn({8});
  const auto path = interpolate_codes(zero, b, 5, true);
  EXPECT_TRUE(at::isfinite(path).all().item<bool>());
  EXPECT_TRUE(at::allclose(path, interpolate_codes(zero, b, 5, false)));
  EXPECT_TRUE(at::isfinite(interpolate_codes(b, zero, 3, true)).all().item<bool>());
}

TEST(LatentOperations, SphericalInterpolationBetweenOppositeCodesIsRefused) {
  // Through the service this answered codes of 1e11 (from [999, ...] to
  // [-999, ...]); the line between them is still there.
  const auto a = at::randn({64});
  const std::vector<std::pair<at::Tensor, at::Tensor>> opposite{
      {a, -a}, {a, -2.5 * a}, {at::full({64}, 999.0f), at::full({64}, -999.0f)}};
  for (const auto& [from, to] : opposite) {
    EXPECT_THROW(interpolate_codes(from, to, 5, true), InputError);
    EXPECT_TRUE(at::isfinite(interpolate_codes(from, to, 5, false)).all().item<bool>());
  }
  // Nearly opposite but apart by more than float rounding: the arc, its
  // codes' norms on the line between the two norms.
  const auto c = -a + 0.05 * at::randn({64});
  const auto path = interpolate_codes(a, c, 5, true);
  const auto norms = path.norm(2, 1);
  const auto line = at::linspace(a.norm().item<float>(), c.norm().item<float>(), 5);
  EXPECT_TRUE(at::allclose(norms, line, 1e-3, 1e-3)) << norms << line;
}

TEST(LatentOperations, AnalogyIsAMinusBPlusC) {
  auto a = at::randn({8}), b = at::randn({8}), c = at::randn({8});
  EXPECT_TRUE(at::allclose(analogy_code(a, b, c), a - b + c));
}

TEST(LatentOperations, CorruptionZeroesAboutHalfOfTheModelledAngles) {
  MM_REQUIRE_H36M();
  const auto& norm = small_h36m().normalization;
  const MotionFrames clip = s5_clip(0, 30);
  const MotionFrames corrupted = corrupt_motion(clip, norm, 0.5, 3);
  int zeroed = 0, total = 0;
  for (int64_t f = 0; f < clip.frame_count(); ++f) {
    for (int c : norm.kept_columns) {
      ++total;
      if (corrupted.frame(f)[c] == 0.0f && clip.frame(f)[c] != 0.0f) ++zeroed;
    }
    EXPECT_EQ(corrupted.frame(f)[0], clip.frame(f)[0]);  // translation untouched
  }
  EXPECT_NEAR(static_cast<double>(zeroed) / total, 0.5, 0.05);
  EXPECT_EQ(corrupt_motion(clip, norm, 0.5, 3).values, corrupted.values);
}

TEST(LatentOperations, DenoiseKeepsTheInputsRootTranslation) {
  MM_REQUIRE_H36M();
  MotionFrames clip = s5_clip(0, 30);
  for (int64_t f = 0; f < clip.frame_count(); ++f) clip.frame(f)[0] = static_cast<float>(f);
  auto denoised = denoise_motions(trained_tiny_model(), {clip}, DecoderKind::kRotation);
  ASSERT_EQ(denoised.size(), 1u);
  EXPECT_EQ(denoised[0].frame(7)[0], 7.0f);
}

// One round with zeros as missing is the plain projection of the motion whose
// zeroed values hold the training mean: the zeros themselves never reach the
// encoder.
TEST(LatentOperations, DenoiseWithZerosAsMissingStartsFromTheTrainingMean) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto& norm = model.normalization();
  const MotionFrames corrupted = corrupt_motion(s5_clip(0, 30), norm, 0.5, 5);
  MotionFrames mean_filled = corrupted;
  for (int64_t f = 0; f < mean_filled.frame_count(); ++f) {
    for (int c : norm.kept_columns) {
      if (mean_filled.frame(f)[c] == 0.0f) mean_filled.frame(f)[c] = norm.mean[c];
    }
  }
  DenoiseOptions one_round;
  one_round.zeros_are_missing = true;
  one_round.iterations = 1;
  const auto expected = denoise_motions(model, {mean_filled}, DecoderKind::kRotation);
  const auto actual = denoise_motions(model, {corrupted}, DecoderKind::kRotation, one_round);
  ASSERT_EQ(actual[0].values.size(), expected[0].values.size());
  for (size_t i = 0; i < actual[0].values.size(); ++i) {
    ASSERT_NEAR(actual[0].values[i], expected[0].values[i], 1e-4) << "value " << i;
  }
  // Further rounds refill the gaps from the decoded motion and change the result.
  one_round.iterations = 3;
  EXPECT_NE(denoise_motions(model, {corrupted}, DecoderKind::kRotation, one_round)[0].values, actual[0].values);
}

TEST(LatentOperations, DenoiseKeepingObservedValuesFillsOnlyTheZeros) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto& norm = model.normalization();
  const MotionFrames corrupted = corrupt_motion(s5_clip(0, 30), norm, 0.5, 6);
  DenoiseOptions fill;
  fill.zeros_are_missing = true;
  fill.keep_observed = true;
  const auto filled = denoise_motions(model, {corrupted}, DecoderKind::kRotation, fill)[0];
  const auto projected = denoise_motions(model, {corrupted}, DecoderKind::kRotation, {true, 4, false})[0];
  int missing = 0;
  for (int64_t f = 0; f < corrupted.frame_count(); ++f) {
    for (int c : norm.kept_columns) {
      const float input = corrupted.frame(f)[c];
      if (input == 0.0f) {
        ++missing;
        EXPECT_FLOAT_EQ(filled.frame(f)[c], projected.frame(f)[c]) << "frame " << f << " column " << c;
      } else {
        EXPECT_NEAR(filled.frame(f)[c], input, 1e-5) << "frame " << f << " column " << c;
      }
    }
  }
  EXPECT_GT(missing, 0);
}

TEST(LatentOperations, ZeroValuesMaskMarksExactZerosOfModelledColumns) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto& kept = model.normalization().kept_columns;
  auto raw = at::ones({2, 3, model.normalization().input_columns()});
  raw[1][2][kept[4]] = 0.0;
  raw[0][0][0] = 0.0;  // root translation is not modelled
  DenoiseOptions zeros;
  zeros.zeros_are_missing = true;
  auto mask = missing_values_mask(model, raw, zeros);
  ASSERT_EQ(mask.sizes(), (std::vector<int64_t>{2, 3, static_cast<int64_t>(kept.size())}));
  EXPECT_EQ(mask.sum().item<int64_t>(), 1);
  EXPECT_TRUE(mask[1][2][4].item<bool>());
  EXPECT_FALSE(missing_values_mask(model, raw, DenoiseOptions{}).defined());
}

TEST(LatentOperations, MeansMaskMarksTheValuesTheReferenceCorruptionDropped) {
  MM_REQUIRE_H36M();
  auto& model = trained_tiny_model();
  const auto& norm = model.normalization();
  // Raw values from the text file (a prepared dataset's clips lie on a grid
  // where values exactly at the mean are common), from frame 20 on (the
  // files' first frames hold exact zeros in the root rotation).
  const MotionFrames full =
      split_phases(read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string()), 2)[0];
  MotionFrames clip;
  clip.columns = full.columns;
  clip.values.assign(full.frame(20), full.frame(50));
  const MotionFrames zeroed = corrupt_motion(clip, norm, 0.3, 11, Corruption::kZeroed);
  const MotionFrames reference = corrupt_motion(clip, norm, 0.3, 11, Corruption::kReference);
  auto raw = [](const MotionFrames& m) {
    return at::from_blob(const_cast<float*>(m.values.data()), {m.frame_count(), m.columns}).clone();
  };
  DenoiseOptions zeros, means;
  zeros.zeros_are_missing = true;
  means.means_are_missing = true;
  // One seed drops the same values under both corruptions: at zero in one,
  // at the training mean in the other, where the means mask finds them.
  const auto dropped = missing_values_mask(model, raw(zeroed), zeros);
  const auto found = missing_values_mask(model, raw(reference), means);
  EXPECT_TRUE(at::equal(dropped, found));
  const double fraction = dropped.to(at::kFloat).mean().item<double>();
  EXPECT_NEAR(fraction, 0.3, 0.03);
  for (int64_t f = 0; f < clip.frame_count(); ++f) {
    for (int c : norm.kept_columns) {
      const float value = reference.frame(f)[c];
      EXPECT_TRUE(value == clip.frame(f)[c] || value == norm.mean[c]) << "frame " << f << " column " << c;
    }
  }
  // Values the model does not see stay as they are.
  EXPECT_EQ(reference.frame(3)[0], clip.frame(3)[0]);
  DenoiseOptions both = zeros;
  both.means_are_missing = true;
  EXPECT_THROW(missing_values_mask(model, raw(clip), both), InputError);
}

TEST(LatentOperations, CorruptionNamesParseAndBadOnesAreNamed) {
  EXPECT_EQ(parse_corruption("reference"), Corruption::kReference);
  EXPECT_EQ(parse_corruption(corruption_name(Corruption::kZeroed)), Corruption::kZeroed);
  try {
    parse_corruption("gaussian");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gaussian"), std::string::npos) << e.what();
  }
}

TEST(LatentOperations, DenoiseRejectsKeepingObservedValuesWithoutMissingOnes) {
  MM_REQUIRE_H36M();
  DenoiseOptions options;
  options.keep_observed = true;
  try {
    denoise_motions(trained_tiny_model(), {s5_clip(0, 30)}, DecoderKind::kRotation, options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keep_observed"), std::string::npos) << e.what();
  }
}

TEST(LatentOperations, DenoiseRejectsFewerThanOneIteration) {
  MM_REQUIRE_H36M();
  DenoiseOptions options;
  options.zeros_are_missing = true;
  options.iterations = 0;
  try {
    denoise_motions(trained_tiny_model(), {s5_clip(0, 30)}, DecoderKind::kRotation, options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("iterations"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mm
