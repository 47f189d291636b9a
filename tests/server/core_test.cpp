// The service core as both frontends use it, on the shipped models: answers
// equal the model library's own, concurrent calls are batched on one
// executor, models are activated while serving and broken ones refused with
// their reason, and limits, tokens and draining behave as documented.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <functional>
#include <mutex>
#include <set>
#include <thread>

#include "core/manifold_core.h"
#include "core/service_metrics.h"
#include "latent_operations.h"
#include "test_environment.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

const CallContext kCall{"test", ""};

// A model store holding links to the shipped models, plus whatever a test adds.
class Store {
 public:
  Store() {
    dir_ = fs::temp_directory_path() / ("mm-core-store-" + std::to_string(getpid()) + "-" + std::to_string(counter_++));
    fs::create_directories(dir_);
    for (const char* name : {"h36m-dkgm-h100", "h36m-dkgm-cpu"}) {
      fs::create_directory_symlink(fs::path(MM_SOURCE_DIR) / "models" / name, dir_ / name);
    }
  }
  ~Store() { fs::remove_all(dir_); }
  // A real copy of a shipped model, to break.
  fs::path copy(const std::string& shipped, const std::string& name) const {
    fs::copy(fs::path(MM_SOURCE_DIR) / "models" / shipped, dir_ / name, fs::copy_options::recursive);
    return dir_ / name;
  }
  std::string path() const { return dir_.string(); }

 private:
  static inline int counter_ = 0;
  fs::path dir_;
};

const MotionManifold& shipped_model() {
  static const MotionManifold model = MotionManifold::load(std::string(MM_SOURCE_DIR) + "/models/h36m-dkgm-h100");
  return model;
}

// 300 frames of S5 walking at 50 Hz, as a client would send them.
Motion walking_at_50_hz() {
  // A test that needs the data fails without it (an exception fails the test).
  if (!test::has_h36m()) throw std::runtime_error("H3.6M not found under " + test::data_dir() + ": run scripts/extract-h36m.sh");
  const auto frames = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  Motion motion;
  motion.frames = 300;
  motion.columns = frames.columns;
  motion.frame_rate = 50;
  motion.layout = kH36mLayout;
  motion.values.assign(frames.values.begin(), frames.values.begin() + 300 * frames.columns);
  return motion;
}

MotionFrames every_second_frame(const Motion& motion) {
  MotionFrames frames;
  frames.columns = motion.columns;
  for (int f = 0; f < motion.frames; f += 2) {
    frames.values.insert(frames.values.end(), motion.values.begin() + f * motion.columns,
                         motion.values.begin() + (f + 1) * motion.columns);
  }
  return frames;
}

float max_difference(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float worst = 0;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) worst = std::max(worst, std::fabs(a[i] - b[i]));
  return worst;
}

// The value of a metric line `name{labels} value` in the exposition text.
double metric(const std::string& text, const std::string& name_and_labels) {
  const auto at = text.find(name_and_labels + " ");
  if (at == std::string::npos) return -1;
  return std::stod(text.substr(at + name_and_labels.size() + 1));
}

class CoreTest : public ::testing::Test {
 protected:
  void start(CoreConfig config = {}) {
    config.model_store = store_.path();
    core_ = std::make_unique<ManifoldCore>(config, metrics_, nullptr);
    core_->start();
  }
  template <typename Call>
  ApiError error_of(Call&& call) {
    try {
      call();
    } catch (const ApiError& e) {
      return e;
    }
    ADD_FAILURE() << "expected an ApiError";
    return ApiError(ErrorCode::kInternal, "", "none");
  }

  Store store_;
  ServiceMetrics metrics_;
  std::unique_ptr<ManifoldCore> core_;
};

TEST_F(CoreTest, EncodeOfA50HzMotionEqualsTheLibraryOnEverySecondFrame) {
  start();
  const Motion motion = walking_at_50_hz();
  const auto reply = core_->encode(kCall, {"", {motion}});
  EXPECT_EQ(reply.answered_by.model, "h36m-dkgm-h100");
  EXPECT_EQ(reply.answered_by.version.size(), 16u);
  const auto expected = encode_motions(shipped_model(), {every_second_frame(motion)});
  ASSERT_EQ(reply.codes.size(), 1u);
  const std::vector<float> library(expected.data_ptr<float>(), expected.data_ptr<float>() + 64);
  EXPECT_LT(max_difference(reply.codes[0], library), 1e-5);
}

TEST_F(CoreTest, ConcurrentDecodesEqualTheLibraryAndRunInBatches) {
  CoreConfig config;
  config.batching.max_queue_delay_us = 20000;
  start(config);
  const auto codes = sample_codes(shipped_model(), 16, 3);
  std::vector<std::vector<float>> answers(16);
  std::vector<std::thread> threads;
  for (int i = 0; i < 16; ++i) {
    threads.emplace_back([&, i] {
      const auto row = codes[i].contiguous();
      DecodeRequest request;
      request.codes = {Code(row.data_ptr<float>(), row.data_ptr<float>() + 64)};
      answers[static_cast<size_t>(i)] = core_->decode({"test", ""}, request).motions.at(0).values;
    });
  }
  for (auto& t : threads) t.join();
  const auto expected = decode_codes(shipped_model(), codes, DecoderKind::kRotation);
  for (int i = 0; i < 16; ++i) EXPECT_LT(max_difference(answers[static_cast<size_t>(i)], expected[static_cast<size_t>(i)].values), 1e-4) << i;
  const std::string text = metrics_.text();
  EXPECT_EQ(metric(text, "mm_batch_clips_sum{operation=\"decode\"}"), 16);
  EXPECT_LT(metric(text, "mm_batch_clips_count{operation=\"decode\"}"), 16) << "no two decodes were batched";
  EXPECT_EQ(metric(text, "mm_requests_total{code=\"OK\",operation=\"decode\",protocol=\"test\"}"), 16);
}

TEST_F(CoreTest, SampleIsReproducibleBySeedAndEqualsTheLibrary) {
  start();
  const auto a = core_->sample(kCall, {"", 2, 11, ""});
  const auto b = core_->sample(kCall, {"", 2, 11, ""});
  const auto c = core_->sample(kCall, {"", 2, 12, ""});
  ASSERT_EQ(a.motions.size(), 2u);
  EXPECT_EQ(a.motions[1].values, b.motions[1].values);
  EXPECT_NE(a.motions[1].values, c.motions[1].values);
  const auto expected = decode_codes(shipped_model(), sample_codes(shipped_model(), 2, 11), DecoderKind::kRotation);
  EXPECT_LT(max_difference(a.motions[1].values, expected[1].values), 1e-4);
  EXPECT_EQ(a.motions[1].frames, 150);
  EXPECT_EQ(a.motions[1].frame_rate, 25);
}

TEST_F(CoreTest, InterpolateAnalogyAndDenoiseEqualTheLibrary) {
  start();
  const Motion motion = walking_at_50_hz();
  const auto frames = every_second_frame(motion);
  const auto& model = shipped_model();
  const auto code = encode_motions(model, {frames})[0];
  const auto other = sample_codes(model, 1, 5)[0];
  const Code other_code(other.data_ptr<float>(), other.data_ptr<float>() + 64);

  InterpolateRequest interpolate;
  interpolate.from.motion = motion;
  interpolate.to.code = other_code;
  interpolate.steps = 3;
  interpolate.method = "spherical";
  const auto interpolated = core_->interpolate(kCall, interpolate);
  const auto expected = decode_codes(model, interpolate_codes(code, other, 3, true), DecoderKind::kRotation);
  ASSERT_EQ(interpolated.motions.size(), 3u);
  EXPECT_LT(max_difference(interpolated.motions[1].values, expected[1].values), 1e-4);

  AnalogyRequest analogy;
  analogy.a.motion = motion;
  analogy.b.code = other_code;
  analogy.c.code = other_code;
  const auto analogous = core_->analogy(kCall, analogy);
  const auto expected_analogy = decode_codes(model, analogy_code(code, other, other).unsqueeze(0), DecoderKind::kRotation);
  EXPECT_LT(max_difference(analogous.motions.at(0).values, expected_analogy[0].values), 1e-4);

  DenoiseRequest denoise;
  denoise.motions = {motion};
  denoise.decoder = "velocity";
  denoise.iterations = 2;
  const auto denoised = core_->denoise(kCall, denoise);
  const auto expected_denoised = denoise_motions(model, {frames}, DecoderKind::kVelocity, {false, 2, false, false});
  EXPECT_LT(max_difference(denoised.motions.at(0).values, expected_denoised[0].values), 1e-4);
}

TEST_F(CoreTest, BadMotionsAreRefusedNamingTheFieldAndWhatWasExpected) {
  start();
  const Motion good = walking_at_50_hz();
  struct Case {
    std::function<void(Motion&)> spoil;
    std::string field, expected;
  };
  const std::vector<Case> cases = {
      {[](Motion& m) { m.columns = 98; }, "motions[0].columns", "expected 99"},
      {[](Motion& m) { m.frames = 299; }, "motions[0].frames", "expected 300 frames at 50 Hz"},
      {[](Motion& m) { m.frame_rate = 30; }, "motions[0].frame_rate", "expected 25 or 50"},
      {[](Motion& m) { m.layout = "bvh"; }, "motions[0].layout", "expected \"h36m-expmap-99\""},
      {[](Motion& m) { m.values.pop_back(); }, "motions[0].values", "expected frames x columns = 29700"},
      {[](Motion& m) { m.values[105] = std::nanf(""); }, "motions[0].values[105]", "found NaN"},
  };
  for (const auto& c : cases) {
    Motion bad = good;
    c.spoil(bad);
    const auto error = error_of([&] { core_->encode(kCall, {"", {bad}}); });
    EXPECT_EQ(error.code(), ErrorCode::kInvalidArgument) << c.field;
    EXPECT_EQ(error.field(), c.field);
    EXPECT_NE(std::string(error.what()).find(c.expected), std::string::npos) << error.what();
  }
  // And it goes on serving.
  EXPECT_EQ(core_->encode(kCall, {"", {good}}).codes.size(), 1u);
}

TEST_F(CoreTest, BadFieldsOfTheOtherOperationsAreRefused) {
  start();
  EXPECT_EQ(error_of([&] { core_->decode(kCall, {"", {Code(63, 0.f)}, ""}); }).field(), "codes[0]");
  EXPECT_EQ(error_of([&] { core_->decode(kCall, {"", {Code(64, 0.f)}, "sideways"}); }).field(), "decoder");
  EXPECT_EQ(error_of([&] { core_->decode(kCall, {"nobody", {Code(64, 0.f)}, ""}); }).code(), ErrorCode::kNotFound);
  EXPECT_EQ(error_of([&] { core_->decode(kCall, {"../models", {Code(64, 0.f)}, ""}); }).code(),
            ErrorCode::kInvalidArgument);
  const auto too_many = error_of([&] { core_->sample(kCall, {"", 65, 0, ""}); });
  EXPECT_EQ(too_many.code(), ErrorCode::kResourceExhausted);
  EXPECT_TRUE(too_many.too_large());
  EXPECT_NE(std::string(too_many.what()).find("max_sample_count"), std::string::npos);
  InterpolateRequest interpolate;
  interpolate.from.code = Code(64, 0.f);
  interpolate.to.code = Code(64, 1.f);
  interpolate.method = "cubic";
  EXPECT_EQ(error_of([&] { core_->interpolate(kCall, interpolate); }).field(), "method");
  interpolate.method = "linear";
  interpolate.to.code.reset();
  EXPECT_EQ(error_of([&] { core_->interpolate(kCall, interpolate); }).field(), "to");
  DenoiseRequest denoise;
  denoise.motions = {walking_at_50_hz()};
  denoise.keep_observed = true;
  EXPECT_EQ(error_of([&] { core_->denoise(kCall, denoise); }).field(), "keep_observed");
}

TEST_F(CoreTest, ActivationWhileServingLetsEveryCallFinish) {
  start();
  std::atomic<bool> done{false};
  std::atomic<int> calls{0}, failures{0};
  std::set<std::string> answered;
  std::mutex answered_mutex;
  std::vector<std::thread> clients;
  for (int t = 0; t < 4; ++t) {
    clients.emplace_back([&] {
      while (!done) {
        try {
          const auto reply = core_->sample(kCall, {"", 1, 1, ""});
          std::lock_guard<std::mutex> lock(answered_mutex);
          answered.insert(reply.answered_by.model);
        } catch (const std::exception&) {
          ++failures;
        }
        ++calls;
      }
    });
  }
  const CallContext call{"test", ""};
  for (int i = 0; i < 6; ++i) {
    const auto name = i % 2 == 0 ? "h36m-dkgm-cpu" : "h36m-dkgm-h100";
    EXPECT_TRUE(core_->activate_model(call, name).active);
    EXPECT_EQ(core_->sample(call, {"", 1, 1, ""}).answered_by.model, name);
  }
  done = true;
  for (auto& c : clients) c.join();
  EXPECT_EQ(failures.load(), 0);
  EXPECT_GT(calls.load(), 6);
  EXPECT_EQ(answered.size(), 2u);
}

TEST_F(CoreTest, ABrokenModelIsReportedWithItsReasonAndTheActiveOneKeepsServing) {
  start();
  fs::remove(store_.copy("h36m-dkgm-cpu", "missing-weights") / "rotation_decoder.pt");
  const auto truncated = store_.copy("h36m-dkgm-cpu", "truncated-weights") / "encoder.pt";
  fs::resize_file(truncated, fs::file_size(truncated) / 2);
  const auto reshaped = store_.copy("h36m-dkgm-cpu", "wrong-shapes") / "manifest.json";
  auto manifest = nlohmann::json::parse(std::ifstream(reshaped));
  manifest["model"]["hidden"] = manifest["model"]["hidden"].get<int>() * 2;
  std::ofstream(reshaped) << manifest.dump();

  for (const char* name : {"missing-weights", "truncated-weights", "wrong-shapes"}) {
    const auto error = error_of([&] { core_->activate_model(kCall, name); });
    EXPECT_EQ(error.code(), ErrorCode::kFailedPrecondition) << name;
    EXPECT_NE(std::string(error.what()).find("cannot be loaded: "), std::string::npos) << error.what();
    EXPECT_EQ(core_->sample(kCall, {"", 1, 0, ""}).answered_by.model, "h36m-dkgm-h100") << name;
  }
  const auto missing = error_of([&] { core_->activate_model(kCall, "missing-weights"); });
  EXPECT_NE(std::string(missing.what()).find("rotation_decoder.pt"), std::string::npos) << missing.what();
  EXPECT_GT(metric(metrics_.text(), "mm_model_load_seconds_count{model=\"wrong-shapes\",outcome=\"failed\"}"), 0);
}

TEST_F(CoreTest, CallsThatChangeStateNeedTheToken) {
  CoreConfig config;
  config.auth_token = "s3cret";
  start(config);
  EXPECT_EQ(error_of([&] { core_->activate_model({"test", ""}, "h36m-dkgm-cpu"); }).code(),
            ErrorCode::kUnauthenticated);
  EXPECT_EQ(error_of([&] { core_->activate_model({"test", "s3cre"}, "h36m-dkgm-cpu"); }).code(),
            ErrorCode::kUnauthenticated);
  EXPECT_EQ(core_->activate_model({"test", "s3cret"}, "h36m-dkgm-cpu").name, "h36m-dkgm-cpu");
  // Reading needs none.
  EXPECT_EQ(core_->list_models({"test", ""}).size(), 2u);
}

TEST_F(CoreTest, AFullQueueRefusesWithResourceExhausted) {
  CoreConfig config;
  config.batching.max_batch = 1;
  config.batching.max_queue_length = 1;
  start(config);
  std::atomic<int> refused{0}, answered{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < 12; ++i) {
    threads.emplace_back([&] {
      try {
        core_->sample(kCall, {"", 4, 0, ""});
        ++answered;
      } catch (const ApiError& e) {
        if (e.code() == ErrorCode::kResourceExhausted && !e.too_large()) ++refused;
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_GT(refused.load(), 0);
  EXPECT_GT(answered.load(), 0);
  EXPECT_EQ(refused.load() + answered.load(), 12);
}

TEST_F(CoreTest, AfterDrainCallsAreUnavailable) {
  start();
  EXPECT_TRUE(core_->ready());
  core_->drain();
  EXPECT_FALSE(core_->ready());
  EXPECT_EQ(error_of([&] { core_->sample(kCall, {"", 1, 0, ""}); }).code(), ErrorCode::kUnavailable);
}

TEST_F(CoreTest, ModelsAreListedAndDescribedWithoutLoadingThem) {
  start();
  const auto models = core_->list_models(kCall);
  ASSERT_EQ(models.size(), 2u);
  EXPECT_EQ(models[0].name, "h36m-dkgm-cpu");
  EXPECT_FALSE(models[0].loaded);
  EXPECT_TRUE(models[1].active);
  EXPECT_EQ(models[1].hidden, 1024);
  EXPECT_EQ(models[1].columns, 99);
  const auto described = core_->describe_model(kCall, "h36m-dkgm-cpu");
  EXPECT_EQ(described.variant, "DKGM");
  EXPECT_FALSE(described.model_card.empty());
  EXPECT_NE(described.evaluation_json.find("paper_units"), std::string::npos);
}

}  // namespace
}  // namespace mm::service
