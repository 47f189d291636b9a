// Inference with packed weights (packed_linear.h): fp32 gives the values of
// the plain products within float rounding, bf16 and int8 stay within a
// bounded distance of fp32 on the shipped model and real S5 clips, and a
// pack never outlives the weights it was made from.
#include <gtest/gtest.h>

#include <c10/core/InferenceMode.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <thread>
#include <vector>

#include "format/input_error.h"
#include "format/motion_text.h"
#include "model/default_model.h"
#include "model/gru_inference.h"
#include "model/motion_manifold.h"
#include "model/packed_linear.h"
#include "tests/common/test_environment.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

double max_relative(const at::Tensor& a, const at::Tensor& b) {
  return ((a - b).abs().max() / b.abs().max()).item<double>();
}

at::Tensor plain_affine(const at::Tensor& weight, const at::Tensor& bias, const at::Tensor& input) {
  auto out = at::empty({input.size(0), weight.size(0)});
  affine_into(out, bias, weight, input);
  return out;
}

TEST(PackedLinear, Fp32MatchesThePlainProductAtEveryBatchSize) {
  at::manual_seed(11);
  const auto weight = at::randn({3072, 1024}) * 0.03, bias = at::randn({3072});
  const PackedLinear packed(weight, bias, Precision::kFp32);
  for (int64_t rows : {1, 2, 30, 61}) {
    const auto input = at::randn({rows, 1024});
    auto out = at::empty({rows, 3072});
    packed.apply(input, out);
    EXPECT_LT(max_relative(out, plain_affine(weight, bias, input)), 1e-5) << rows << " rows";
  }
}

TEST(PackedLinear, Bf16IsWithinBf16RoundingOfFp32) {
  if (!precision_available(Precision::kBf16)) GTEST_SKIP() << "no bf16 dot products on this CPU or build";
  at::manual_seed(12);
  const auto weight = at::randn({3072, 1024}) * 0.03, bias = at::randn({3072});
  const PackedLinear packed(weight, bias, Precision::kBf16);
  const auto input = at::randn({30, 1024});
  auto out = at::empty({30, 3072});
  packed.apply(input, out);
  // bf16 keeps 8 significant bits (relative rounding 2^-9 = 0.2% per value);
  // sums of 1,024 products with random signs stay near that.
  const double error = max_relative(out, plain_affine(weight, bias, input));
  EXPECT_LT(error, 1e-2);
  EXPECT_GT(error, 1e-5);  // it really is bf16, not fp32
}

// int8 quantises the weight per output row and the input per row to 8 bits
// (a step of 1/127 of the row's largest value): coarser than bf16's 8
// significant bits, but bounded, at batch 1 and batched alike.
TEST(PackedLinear, Int8IsWithinItsQuantisationOfFp32) {
  if (!precision_available(Precision::kInt8)) GTEST_SKIP() << "no bf16 dot products on this CPU or build";
  at::manual_seed(14);
  const auto weight = at::randn({3072, 1024}) * 0.03, bias = at::randn({3072});
  const PackedLinear packed(weight, bias, Precision::kInt8);
  for (int64_t rows : {1, 30}) {
    // Rows of different magnitudes: each has its own scale.
    const auto input = at::tanh(at::randn({rows, 1024})) * at::linspace(0.01, 1, rows).unsqueeze(1);
    auto out = at::empty({rows, 3072});
    packed.apply(input, out);
    const auto expected = plain_affine(weight, bias, input);
    const auto error = ((out - expected).abs().amax(1) / (expected - bias).abs().amax(1)).max().item<double>();
    std::printf("int8 against fp32, %ld rows: %.2e of the product's largest value, at most\n",
                static_cast<long>(rows), error);
    EXPECT_LT(error, 2e-2) << rows << " rows";
    EXPECT_GT(error, 1e-3) << rows << " rows";  // it really is int8, not bf16 or fp32
  }
}

// A row of zeros (the encoder's first hidden state) gives the bias exactly;
// a row holding a NaN gives NaN, as fp32 would, and leaves the others be.
TEST(PackedLinear, Int8KeepsZeroAndNanRowsApart) {
  if (!precision_available(Precision::kInt8)) GTEST_SKIP() << "no bf16 dot products on this CPU or build";
  at::manual_seed(15);
  const auto weight = at::randn({64, 32}), bias = at::randn({64});
  const PackedLinear packed(weight, bias, Precision::kInt8);
  auto input = at::rand({3, 32});
  input[0].zero_();
  input[1][5] = std::numeric_limits<float>::quiet_NaN();
  auto out = at::empty({3, 64});
  packed.apply(input, out);
  EXPECT_TRUE(at::equal(out[0], bias));
  EXPECT_TRUE(out[1].isnan().all().item<bool>());
  EXPECT_FALSE(out[2].isnan().any().item<bool>());
  EXPECT_LT(max_relative(out[2], plain_affine(weight, bias, input.narrow(0, 2, 1))[0]), 2e-2);
}

TEST(PackedLinear, ConcurrentCallsGiveTheSameValues) {
  at::manual_seed(13);
  const auto weight = at::randn({512, 256}), bias = at::randn({512});
  for (auto precision : {Precision::kFp32, Precision::kBf16, Precision::kInt8}) {
    if (!precision_available(precision)) continue;
    const PackedLinear packed(weight, bias, precision);
    const auto input = at::randn({30, 256});
    auto expected = at::empty({30, 512});
    packed.apply(input, expected);
    std::vector<at::Tensor> outs(4);
    std::vector<std::thread> threads;
    for (auto& out : outs) {
      out = at::empty({30, 512});
      threads.emplace_back([&packed, &input, &out] {
        for (int i = 0; i < 50; ++i) packed.apply(input, out);
      });
    }
    for (auto& t : threads) t.join();
    for (const auto& out : outs) EXPECT_TRUE(at::equal(out, expected)) << precision_name(precision);
  }
}

TEST(PackedLinear, KnowsWhenItsWeightsChanged) {
  auto weight = at::randn({8, 4}), bias = at::randn({8});
  const PackedLinear packed(weight, bias, Precision::kFp32);
  EXPECT_TRUE(packed.current());
  weight.add_(1.0);  // as an optimiser step does
  EXPECT_FALSE(packed.current());
}

// The fused element-wise step against the GRU's gate formulas written with
// LibTorch's own sigmoid and tanh, over pre-activations from -100 to 100
// (its e^x is clamped past +-87), and a NaN stays a NaN.
TEST(GruCombine, FollowsTheGateFormulasOfLibTorch) {
  torch::manual_seed(3);
  const int64_t size = 1000;
  const auto input_gates = at::linspace(-100, 100, 3 * size).view({1, 3 * size});
  const auto hidden_gates = at::randn({1, 3 * size}) * 3;
  const auto start = at::rand({1, size}) * 2 - 1;
  auto gate = [&](const at::Tensor& t, int64_t k) { return t.narrow(1, k * size, size); };
  const auto reset = (gate(input_gates, 0) + gate(hidden_gates, 0)).sigmoid();
  const auto update = (gate(input_gates, 1) + gate(hidden_gates, 1)).sigmoid();
  const auto candidate = (gate(input_gates, 2) + reset * gate(hidden_gates, 2)).tanh();
  const auto expected = (1 - update) * candidate + update * start;
  auto hidden = start.clone();
  gru_combine(hidden, input_gates, hidden_gates);
  const double error = (hidden - expected).abs().max().item<double>();
  std::printf("fused GRU step against LibTorch's: %.2e at most\n", error);
  EXPECT_LT(error, 3e-7);  // measured 1.2e-7; without e^x's r^6 term 7e-7
  auto with_nan = start.clone();
  auto nan_gates = input_gates.clone();
  nan_gates[0][2 * size + 7] = std::numeric_limits<float>::quiet_NaN();
  gru_combine(with_nan, nan_gates, hidden_gates);
  EXPECT_TRUE(std::isnan(with_nan[0][7].item<float>()));
}

TEST(PackedLinear, NamesThePrecisions) {
  EXPECT_EQ(parse_precision("bf16", "precision"), Precision::kBf16);
  EXPECT_EQ(parse_precision("int8", "precision"), Precision::kInt8);
  EXPECT_STREQ(precision_name(Precision::kFp32), "fp32");
  EXPECT_STREQ(precision_name(Precision::kInt8), "int8");
  try {
    parse_precision("fp16", "--precision");
    FAIL() << "fp16 accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--precision: unknown value \"fp16\""), std::string::npos);
  }
}

// A small untrained model: its packed paths against its plain ones.
MotionManifold small_model() {
  torch::manual_seed(5);
  ModelConfig config;
  config.hidden = 96;
  config.frames = 30;
  MotionManifold model(config, test::small_h36m().normalization, Skeleton::h36m());
  model.train(false);
  return model;
}

TEST(PackedInference, Fp32PacksEncodeAndDecodeAsThePlainPaths) {
  MM_REQUIRE_H36M();
  MotionManifold model = small_model();
  const auto clips = at::randn({3, 30, 51});
  const auto code = model.encode(clips);
  const auto rotation = model.decode(code, DecoderKind::kRotation);
  const auto velocity = model.decode(code, DecoderKind::kVelocity);
  model.pack_for_inference(Precision::kFp32);
  ASSERT_EQ(model.inference_precision(), Precision::kFp32);
  EXPECT_LT(max_relative(model.encode(clips), code), 1e-5);
  EXPECT_LT(max_relative(model.decode(code, DecoderKind::kRotation), rotation), 1e-5);
  EXPECT_LT(max_relative(model.decode(code, DecoderKind::kVelocity), velocity), 1e-5);
  model.train(true);  // training is about to change the weights: the packs go
  EXPECT_FALSE(model.inference_precision().has_value());
}

// A model loaded inside c10::InferenceMode (as the tool's commands load
// theirs) holds inference tensors, which keep no change count: it packs
// and answers as one loaded outside.
TEST(PackedInference, AModelLoadedInsideInferenceModePacksAndDecodes) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  small_model().save(dir.path().string());
  const MotionManifold outside = MotionManifold::load(dir.path().string());
  c10::InferenceMode inference;
  const MotionManifold inside = MotionManifold::load(dir.path().string());
  ASSERT_EQ(inside.inference_precision(), outside.inference_precision());
  const auto code = at::randn({2, 64});
  EXPECT_LT(max_relative(inside.decode(code, DecoderKind::kRotation), outside.decode(code, DecoderKind::kRotation)),
            1e-6);
  const auto clips = at::randn({2, 30, 51});
  EXPECT_LT(max_relative(inside.encode(clips), outside.encode(clips)), 1e-6);
}

TEST(PackedInference, WeightsChangedInPlaceAreUsedAsTheyAreNow) {
  MM_REQUIRE_H36M();
  MotionManifold model = small_model();
  model.pack_for_inference(Precision::kFp32);
  const auto code = at::randn({2, 64});
  const auto before = model.decode(code, DecoderKind::kRotation);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : model.generator_parameters()) p.mul_(1.5);  // in place, as an optimiser step does
  }
  const auto after = model.decode(code, DecoderKind::kRotation);
  torch::NoGradGuard no_grad;
  const auto expected = model.decoder(DecoderKind::kRotation)->forward(code);
  EXPECT_LT(max_relative(after, expected), 1e-4);
  EXPECT_GT(max_relative(before, expected), 1e-2);
}

// The shipped model on four real S5 clips at 25 Hz, 2 s into each take,
// reconstructed (encode, then decode) in fp32 and in `precision`: the mean
// pose error of each, and how far apart their decoded joints lie (mm).
struct AgainstFp32 {
  double pose_error, fp32_pose_error, apart_mm;
};

AgainstFp32 reconstruct_against_fp32(Precision precision) {
  MotionManifold model = MotionManifold::load(default_model_dir());
  std::vector<at::Tensor> clips;
  for (const char* take : {"walking_1.txt", "eating_1.txt", "greeting_1.txt", "phoning_1.txt"}) {
    const auto frames = split_phases(read_motion_text((test::h36m_dataset_dir() / "S5" / take).string()), 2)[0];
    auto all = at::from_blob(const_cast<float*>(frames.values.data()), {frames.frame_count(), frames.columns});
    clips.push_back(all.narrow(0, 50, model.config().frames).clone());
  }
  const auto normalized = model.to_normalized(at::stack(clips));
  auto reconstruct = [&] { return model.decode(model.encode(normalized), DecoderKind::kRotation); };
  const auto fp32 = reconstruct();
  model.pack_for_inference(precision);
  const auto other = reconstruct();
  auto pose_error = [&](const at::Tensor& decoded) { return (decoded - normalized).norm(2, -1).mean().item<double>(); };
  const AgainstFp32 result{pose_error(other), pose_error(fp32),
                           (model.positions_mm(other) - model.positions_mm(fp32)).norm(2, -1).mean().item<double>()};
  std::printf("%s against fp32: pose error %.4f against %.4f; joints %.2f mm apart on average\n",
              precision_name(precision), result.pose_error, result.fp32_pose_error, result.apart_mm);
  return result;
}

// bf16: the reconstruction error moves by under 1% and the decoded poses
// stay within a few millimetres of fp32's.
TEST(PackedInference, Bf16ReconstructsRealClipsAsFp32Does) {
  MM_REQUIRE_H36M();
  if (!precision_available(Precision::kBf16)) GTEST_SKIP() << "no bf16 dot products on this CPU or build";
  const auto bf16 = reconstruct_against_fp32(Precision::kBf16);
  EXPECT_LT(std::abs(bf16.pose_error / bf16.fp32_pose_error - 1.0), 0.01);
  EXPECT_LT(bf16.apart_mm, 2.0);  // measured 0.58 mm (the default model at 36,103 iterations)
  EXPECT_GT(bf16.apart_mm, 0.0);
}

// int8: the same bound on the reconstruction error (the condition on which
// the option is offered), its joints further from fp32's than bf16's are.
TEST(PackedInference, Int8ReconstructsRealClipsAsFp32Does) {
  MM_REQUIRE_H36M();
  if (!precision_available(Precision::kInt8)) GTEST_SKIP() << "no bf16 dot products on this CPU or build";
  const auto int8 = reconstruct_against_fp32(Precision::kInt8);
  EXPECT_LT(std::abs(int8.pose_error / int8.fp32_pose_error - 1.0), 0.01);
  EXPECT_LT(int8.apart_mm, 5.0);  // measured 1.88 mm (the default model at 36,103 iterations)
  EXPECT_GT(int8.apart_mm, 0.0);
}

}  // namespace
}  // namespace mm
