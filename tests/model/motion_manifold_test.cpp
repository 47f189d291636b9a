#include "model/motion_manifold.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "format/input_error.h"
#include "tests/model/model_test_data.h"

namespace mm {
namespace {

using test::small_h36m;

MotionManifold tiny_model() {
  at::manual_seed(11);
  auto config = test::tiny_config().model;
  return MotionManifold(config, small_h36m().normalization, Skeleton::h36m());
}

TEST(MotionManifold, SavedAndLoadedModelGivesIdenticalOutputs) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  MotionManifold model = tiny_model();
  model.train(false);
  model.save(dir.file("model"), R"({"note": "test"})");
  MotionManifold loaded = MotionManifold::load(dir.file("model"));
  // A loaded model multiplies with fp32 packs; the same packs here give the
  // same products, bit for bit.
  EXPECT_EQ(loaded.inference_precision(), Precision::kFp32);
  model.pack_for_inference(Precision::kFp32);
  auto motion = at::randn({2, 30, 51});
  auto code = model.encode(motion);
  EXPECT_TRUE(at::equal(code, loaded.encode(motion)));
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    EXPECT_TRUE(at::equal(model.decode(code, kind), loaded.decode(code, kind))) << decoder_name(kind);
  }
  EXPECT_EQ(loaded.normalization().to_json_text(), model.normalization().to_json_text());
  EXPECT_EQ(loaded.config().hidden, 48);
  EXPECT_EQ(loaded.provenance_json(), R"({"note":"test"})");
}

TEST(MotionManifold, NormalisationRoundTripsThroughRawFrames) {
  MM_REQUIRE_H36M();
  MotionManifold model = tiny_model();
  auto normalized = at::randn({4, 51});
  auto raw = model.to_raw(normalized);
  ASSERT_EQ(raw.size(-1), 99);
  EXPECT_TRUE(at::allclose(model.to_normalized(raw), normalized, 1e-4, 1e-5));
  EXPECT_TRUE(at::equal(raw.narrow(-1, 0, 3), at::zeros({4, 3})));  // no root translation
}

TEST(MotionManifold, LoadNamesTheMissingWeightsFile) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  tiny_model().save(dir.file("model"));
  std::filesystem::remove(dir.file("model/velocity_decoder.pt"));
  try {
    MotionManifold::load(dir.file("model"));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("velocity_decoder.pt"), std::string::npos) << e.what();
  }
}

TEST(MotionManifold, LoadRefusesWeightsOfAnotherNetworkSize) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  tiny_model().save(dir.file("model"));
  // The manifest now claims a larger network than the weights hold.
  std::ifstream in(dir.file("model/manifest.json"));
  std::string manifest((std::istreambuf_iterator<char>(in)), {});
  const auto at = manifest.find("\"hidden\": 48");
  ASSERT_NE(at, std::string::npos) << manifest.substr(0, 300);
  manifest.replace(at, 12, "\"hidden\": 96");
  std::ofstream(dir.file("model/manifest.json")) << manifest;
  try {
    MotionManifold::load(dir.file("model"));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("encoder.pt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("has shape"), std::string::npos) << e.what();
  }
}

TEST(MotionManifold, LoadRejectsACorruptManifest) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  tiny_model().save(dir.file("model"));
  std::ofstream(dir.file("model/manifest.json")) << "{\"format\": \"something else\"}";
  try {
    MotionManifold::load(dir.file("model"));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("manifest.json"), std::string::npos) << e.what();
  }
}

TEST(MotionManifold, DecodingWithAnAbsentDecoderIsAnInputError) {
  MM_REQUIRE_H36M();
  auto config = variant_config("Seq2seq").model;
  config.hidden = 16;
  config.latent = 4;
  config.frames = 10;
  MotionManifold model(config, small_h36m().normalization, Skeleton::h36m());
  EXPECT_EQ(model.default_decoder(), DecoderKind::kVelocity);
  EXPECT_THROW(model.decode(at::zeros({1, 4}), DecoderKind::kRotation), InputError);
}

}  // namespace
}  // namespace mm
