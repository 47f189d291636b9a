// The service core as both frontends use it, on the shipped models: answers
// equal the model library's own, concurrent calls are batched on one
// executor, models are activated while serving and broken ones refused with
// their reason, limits, tokens and draining behave as documented, and the
// clips of the data root are listed and read as the files hold them.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <functional>
#include <limits>
#include <mutex>
#include <set>
#include <thread>

#include "format/bvh_file.h"
#include "format/h36m_bvh.h"
#include "format/input_error.h"
#include "format/motion_text.h"
#include "model/latent_operations.h"
#include "server/api/data_root_path.h"
#include "server/core/service_metrics.h"
#include "server/engine/manifold_core.h"
#include "server/engine/model_store.h"
#include "server/jobs/job_spec_check.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/command_run.h"
#include "tests/common/joined_threads.h"
#include "tests/common/test_environment.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

const CallContext kCall{"test", "", "", "127.0.0.1"};

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
  // Each row of `codes` decoded by a call of its own with the decoder
  // `decoder_of(row)` ("" the model's default), all calls at once.
  std::vector<std::vector<float>> decode_rows_at_once(const at::Tensor& codes,
                                                      const std::function<std::string(int)>& decoder_of) {
    const int rows = static_cast<int>(codes.size(0));
    std::vector<std::vector<float>> answers(static_cast<size_t>(rows));
    mm::test::JoinedThreads threads;
    for (int i = 0; i < rows; ++i) {
      threads.start([&, i] {
        const auto row = codes[i].contiguous();
        DecodeRequest request;
        request.codes = {Code(row.data_ptr<float>(), row.data_ptr<float>() + 64)};
        request.decoder = decoder_of(i);
        answers[static_cast<size_t>(i)] = core_->decode({"test", ""}, request).motions.at(0).values;
      });
    }
    threads.join();
    return answers;
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
  const auto answers = decode_rows_at_once(codes, [](int) { return std::string(); });
  const auto expected = decode_codes(shipped_model(), codes, DecoderKind::kRotation);
  // Relative to the value: the root's path is in mm, hundreds of them.
  for (int i = 0; i < 16; ++i) {
    const auto& answer = answers[static_cast<size_t>(i)];
    const auto& want = expected[static_cast<size_t>(i)].values;
    ASSERT_EQ(answer.size(), want.size());
    double largest = 0;
    for (size_t v = 0; v < want.size(); ++v) largest = std::max(largest, std::fabs(answer[v] - want[v]) / (1.0 + std::fabs(want[v])));
    EXPECT_LT(largest, 1e-4) << i;
  }
  const std::string text = metrics_.text();
  EXPECT_EQ(metric(text, "mm_batch_clips_sum{operation=\"decode\"}"), 16);
  EXPECT_LT(metric(text, "mm_batch_clips_count{operation=\"decode\"}"), 16) << "no two decodes were batched";
  EXPECT_EQ(metric(text, "mm_requests_total{code=\"OK\",operation=\"decode\",protocol=\"test\"}"), 16);
}

// Calls that differ only in their decoder arrive together: each is answered
// by the decoder it asked for, never by its batch neighbour's.
TEST_F(CoreTest, ConcurrentDecodesOfEitherDecoderEachGetTheirOwnDecoder) {
  CoreConfig config;
  config.batching.max_queue_delay_us = 20000;
  start(config);
  const auto codes = sample_codes(shipped_model(), 16, 5);
  auto decoder_of = [](int i) { return i % 2 == 0 ? std::string("rotation") : std::string("velocity"); };
  const auto answers = decode_rows_at_once(codes, decoder_of);
  const auto by_rotation = decode_codes(shipped_model(), codes, DecoderKind::kRotation);
  const auto by_velocity = decode_codes(shipped_model(), codes, DecoderKind::kVelocity);
  auto largest_difference = [](const std::vector<float>& a, const std::vector<float>& b) {
    double largest = 0;
    for (size_t v = 0; v < b.size(); ++v) largest = std::max(largest, std::fabs(a[v] - b[v]) / (1.0 + std::fabs(b[v])));
    return largest;
  };
  for (int i = 0; i < 16; ++i) {
    const auto& answer = answers[static_cast<size_t>(i)];
    const auto& own = (i % 2 == 0 ? by_rotation : by_velocity)[static_cast<size_t>(i)].values;
    const auto& other = (i % 2 == 0 ? by_velocity : by_rotation)[static_cast<size_t>(i)].values;
    ASSERT_EQ(answer.size(), own.size());
    EXPECT_LT(largest_difference(answer, own), 1e-4) << i << " (" << decoder_of(i) << ")";
    // The two decoders differ far beyond that tolerance, so the check above
    // tells them apart.
    EXPECT_GT(largest_difference(other, own), 1e-2) << i;
  }
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

// DenoiseTake with keep_observed fits at most takes.max_gap_fits windows a
// take (--max-take-gap-fits; here 1) to its gaps: a take of three gaps of
// every joint (1 s each, 5 s apart) is answered whole, and its summary
// counts one window and one gap fitted and two gaps left to the matched
// fill; with gap_fill "matched" nothing is fitted. 62 s at a load of 8 on
// two cores (36 s of CPU).
TEST_F(CoreTest, ATakeWithMoreGapsThanTheFitBoundIsAnsweredAndItsSummaryCountsThem) {
  CoreConfig config;
  config.takes.max_gap_fits = 1;
  start(config);
  if (!test::has_h36m()) GTEST_SKIP() << "H3.6M not found";
  MotionFrames take = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
  take.values.resize(static_cast<size_t>(800 * take.columns));  // 16 s at 50 Hz
  for (int64_t first : {100, 350, 600}) {
    for (int64_t f = first; f < first + 50; ++f) {
      std::fill(take.frame(f) + 3, take.frame(f) + take.columns, std::numeric_limits<float>::quiet_NaN());
    }
  }
  TakeRequest request;
  request.frame_rate = 50;
  request.keep_observed = true;
  int64_t frames = 0;
  TakeReplySink sink;
  sink.on_frames = [&frames](const float*, const float*, int64_t count) { frames += count; };
  auto run = [&] {
    bool sent = false;
    frames = 0;
    return core_->run_take(kCall, TakeOperation::kDenoise, request, [&](TakeChunk& chunk) {
      if (sent) return false;
      chunk.frames = take.frame_count();
      chunk.values = take.values;
      return sent = true;
    }, sink);
  };
  const TakeSummary bounded = run();
  EXPECT_EQ(frames, 800);
  EXPECT_EQ(bounded.gap_windows_fitted, 1);
  EXPECT_EQ(bounded.gaps_fitted, 1);
  EXPECT_EQ(bounded.gaps_over_fit_limit, 2);
  request.gap_fill = "matched";
  const TakeSummary matched = run();
  EXPECT_EQ(matched.gap_windows_fitted, 0);
  EXPECT_EQ(matched.gaps_over_fit_limit, 0);
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
  mm::test::JoinedThreads clients([&] { done = true; });
  for (int t = 0; t < 4; ++t) {
    clients.start([&] {
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
  const CallContext call{"test", "", "", "127.0.0.1"};
  for (int i = 0; i < 6; ++i) {
    const auto name = i % 2 == 0 ? "h36m-dkgm-cpu" : "h36m-dkgm-h100";
    EXPECT_TRUE(core_->activate_model(call, name).active);
    EXPECT_EQ(core_->sample(call, {"", 1, 1, ""}).answered_by.model, name);
  }
  clients.join();
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

TEST(ModelStoreDeletion, ACallHoldingADeletedModelFinishesOnItAndNoLaterCallFindsIt) {
  Store store;
  const fs::path copy = store.copy("h36m-dkgm-cpu", "doomed");
  ServiceMetrics metrics;
  ModelStore models(store.path(), metrics);
  models.activate("h36m-dkgm-h100");
  const auto held = models.get("doomed");  // as a call in flight holds it
  const auto before = decode_codes(held->model, sample_codes(held->model, 1, 5), held->model.default_decoder());
  EXPECT_EQ(models.remove("doomed").name, "doomed");
  EXPECT_FALSE(fs::exists(copy));
  const auto after = decode_codes(held->model, sample_codes(held->model, 1, 5), held->model.default_decoder());
  EXPECT_EQ(after.front().values, before.front().values);
  for (const auto& call : std::vector<std::function<void()>>{[&] { models.get("doomed"); },
                                                            [&] { models.activate("doomed"); },
                                                            [&] { models.remove("doomed"); }}) {
    try {
      call();
      ADD_FAILURE() << "the deleted model was found";
    } catch (const ApiError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kNotFound) << e.what();
    }
  }
  EXPECT_EQ(models.list().size(), 2u);
  // Deleted by another replica sharing the store: no longer answered by name.
  const fs::path elsewhere = store.copy("h36m-dkgm-cpu", "elsewhere");
  models.get("elsewhere");
  fs::remove_all(elsewhere);
  try {
    models.get("elsewhere");
    ADD_FAILURE() << "a model deleted from the store was answered from memory";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound) << e.what();
  }
  try {
    models.remove("h36m-dkgm-h100");
    ADD_FAILURE() << "the active model was deleted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kFailedPrecondition) << e.what();
  }
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
  mm::test::JoinedThreads threads;
  for (int i = 0; i < 12; ++i) {
    threads.start([&] {
      try {
        core_->sample(kCall, {"", 4, 0, ""});
        ++answered;
      } catch (const ApiError& e) {
        if (e.code() == ErrorCode::kResourceExhausted && !e.too_large()) ++refused;
      }
    });
  }
  threads.join();
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

// A call whose body a frontend reads for the model that answers it (REST's
// BVH bodies) begins with choose_model and is a call like every other: an
// unknown model is NOT_FOUND and, after drain(), UNAVAILABLE, both before any
// body is read and both counted; a body the frontend cannot read is the
// call's INVALID_ARGUMENT (refuse_body), counted too; the operation runs on
// the model chosen, whose shape the body was read for. The chosen model's
// call is in flight until its handle goes (drain() waits for it), and a
// handle let go with no outcome is counted as INTERNAL.
TEST_F(CoreTest, ACallReadForItsModelIsRefusedAndCountedAsEveryCall) {
  start();
  {
    const ChosenModel chosen = core_->choose_model(kCall, "encode", "h36m-dkgm-cpu");
    const ModelShape& shape = chosen.shape();
    EXPECT_EQ(chosen.model().model, "h36m-dkgm-cpu");
    EXPECT_EQ(shape.columns, 99);
    Motion motion;
    motion.frames = shape.frames;
    motion.columns = shape.columns;
    motion.frame_rate = 25;
    motion.layout = shape.layout;
    motion.values.assign(static_cast<size_t>(shape.frames * shape.columns), 0.1f);
    EncodeRequest request;  // its model is not read: the chosen one answers
    request.motions.push_back(motion);
    const EncodeReply reply = core_->encode(kCall, request, chosen);
    EXPECT_EQ(reply.answered_by.model, "h36m-dkgm-cpu");
    EXPECT_EQ(reply.answered_by.version, chosen.model().version);
    EXPECT_EQ(static_cast<int>(reply.codes.at(0).size()), shape.latent);
    // One handle, one call: its call has ended, and nothing more is counted.
    EXPECT_EQ(error_of([&] { core_->encode(kCall, request, chosen); }).code(), ErrorCode::kInternal);
  }
  {
    const ChosenModel unreadable = core_->choose_model(kCall, "encode", "");
    core_->refuse_body(unreadable, ApiError(ErrorCode::kInvalidArgument, "", "request body:3: not a BVH"));
  }
  EXPECT_EQ(error_of([&] { core_->choose_model(kCall, "encode", "missing"); }).code(), ErrorCode::kNotFound);

  ChosenModel held = core_->choose_model(kCall, "encode", "");
  std::atomic<bool> drained{false};
  std::thread drain([&] {
    core_->drain();
    drained = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_FALSE(drained) << "drain() returned while a chosen model's call was in flight";
  held = ChosenModel();  // let go with no outcome
  drain.join();
  EXPECT_TRUE(drained);
  EXPECT_EQ(error_of([&] { core_->choose_model(kCall, "encode", ""); }).code(), ErrorCode::kUnavailable);

  const std::string text = metrics_.text();
  for (const std::string code : {"OK", "INVALID_ARGUMENT", "NOT_FOUND", "UNAVAILABLE", "INTERNAL"}) {
    const std::string labels = "{code=\"" + code + "\",operation=\"encode\",protocol=\"test\"}";
    EXPECT_EQ(metric(text, "mm_requests_total" + labels), 1) << code;
  }
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

// ---------------------------------------------------------------- clips of the data root

// A data root of real files (copies: a link out of the root is not one of
// its clips) beside things that are not clips, and a file outside it.
class DataRoot {
 public:
  DataRoot() {
    fs::create_directories(root() / "h36m" / "S1");
    fs::create_directories(root() / "h36m" / "S5");
    fs::copy_file(test::h36m_dataset_dir() / "S1" / "walking_1.txt", root() / "h36m" / "S1" / "walking_1.txt");
    fs::copy_file(test::h36m_dataset_dir() / "S5" / "eating_1.txt", root() / "h36m" / "S5" / "eating_1.txt");
    // The first 400 rows of S5 walking as BVH of the H3.6M skeleton at 50 Hz.
    auto rows = read_motion_text((test::h36m_dataset_dir() / "S5" / "walking_1.txt").string());
    rows.values.resize(400 * static_cast<size_t>(rows.columns));
    fs::create_directories(root() / "bvh");
    write_bvh_file(h36m_motion_to_bvh(rows, 50), (root() / "bvh" / "walking.bvh").string());
    fs::copy_file(test::cmu_dance_dir() / "indian" / "04.bvh", root() / "bvh" / "Dance.BVH");
    std::ofstream(root() / "README.md") << "not a clip\n";
    std::ofstream(root() / "bad.txt") << "0,0,0\n";
    fs::create_directories(root() / ".cache");
    std::ofstream(root() / ".cache" / "hidden.txt") << "0\n";
    std::ofstream(root() / ".hidden.bvh") << "0\n";
    std::ofstream(dir_.path() / "outside.txt") << "0\n";
    fs::create_symlink(dir_.path() / "outside.txt", root() / "link_out.txt");
    fs::create_directory_symlink(dir_.path(), root() / "folder_link");
  }
  fs::path root() const { return dir_.path() / "root"; }

 private:
  test::ScratchDir dir_;
};

class CoreClipsTest : public CoreTest {
 protected:
  void SetUp() override { MM_REQUIRE_H36M(); }
  void start_with_data_root(CoreConfig config = {}) {
    data_ = std::make_unique<DataRoot>();
    config.data_root = data_->root().string();
    start(config);
  }
  ReadClipReply read(const std::string& path, int64_t start) { return core_->read_clip(kCall, {"", path, start}); }

  std::unique_ptr<DataRoot> data_;
};

TEST_F(CoreClipsTest, EveryTextAndBvhFileUnderTheRootIsListedSortedWithItsFormatAndSize) {
  start_with_data_root();
  const auto reply = core_->list_clips(kCall);
  EXPECT_FALSE(reply.truncated);
  std::vector<std::string> listed;
  for (const auto& clip : reply.clips) {
    listed.push_back(clip.path + " " + clip.format);
    EXPECT_EQ(clip.size_bytes, static_cast<int64_t>(fs::file_size(data_->root() / clip.path))) << clip.path;
  }
  // Not listed: README.md, hidden files and folders, the link out of the
  // root and what lies behind the link to a folder.
  EXPECT_EQ(listed, (std::vector<std::string>{"bad.txt h36m-text", "bvh/Dance.BVH bvh", "bvh/walking.bvh bvh",
                                              "h36m/S1/walking_1.txt h36m-text", "h36m/S5/eating_1.txt h36m-text"}));
}

TEST_F(CoreClipsTest, AListLongerThanTheLimitIsCutAndSaysSo) {
  CoreConfig config;
  config.max_listed_clips = 2;
  start_with_data_root(config);
  const auto reply = core_->list_clips(kCall);
  EXPECT_TRUE(reply.truncated);
  ASSERT_EQ(reply.clips.size(), 2u);
  EXPECT_EQ(reply.clips[1].path, "bvh/Dance.BVH");
}

TEST_F(CoreClipsTest, ATextWindowIsEverySecondRowFromStartAndEncodesAsTheRaw50HzRows) {
  start_with_data_root();
  const auto rows = read_motion_text((test::h36m_dataset_dir() / "S1" / "walking_1.txt").string());
  const int64_t start = 101;  // odd: the rows kept are the odd ones
  const auto reply = read("h36m/S1/walking_1.txt", start);
  EXPECT_EQ(reply.path, "h36m/S1/walking_1.txt");
  EXPECT_EQ(reply.format, "h36m-text");
  EXPECT_EQ(reply.start, start);
  EXPECT_EQ(reply.file_frames, rows.frame_count());
  EXPECT_EQ(reply.file_frame_rate, 50);
  EXPECT_EQ(reply.last_start, rows.frame_count() - 300);
  const Motion& motion = reply.motion;
  EXPECT_EQ(motion.frames, 150);
  EXPECT_EQ(motion.columns, 99);
  EXPECT_EQ(motion.frame_rate, 25);
  EXPECT_EQ(motion.layout, "h36m-expmap-99");
  std::vector<float> expected;
  for (int64_t k = 0; k < 150; ++k) expected.insert(expected.end(), rows.frame(start + 2 * k), rows.frame(start + 2 * k) + 99);
  EXPECT_EQ(motion.values, expected);

  Motion raw;
  raw.frames = 300;
  raw.columns = 99;
  raw.frame_rate = 50;
  raw.layout = kH36mLayout;
  raw.values.assign(rows.frame(start), rows.frame(start + 300));
  EXPECT_EQ(core_->encode(kCall, {"", {motion}}).codes, core_->encode(kCall, {"", {raw}}).codes);
  // The last full window is read; one frame further is refused.
  EXPECT_EQ(read("h36m/S1/walking_1.txt", reply.last_start).motion.frames, 150);
}

TEST_F(CoreClipsTest, ABvhOfTheModelsSkeletonIsItsImportFromStartAndAnotherSkeletonKeepsItsOwn) {
  start_with_data_root();
  const auto file = read_bvh_file((data_->root() / "bvh" / "walking.bvh").string());
  const auto whole = skeleton_motion_from_bvh(Skeleton::h36m(), file, "walking.bvh");  // 25 Hz: file frames 0, 2, ...
  const auto reply = read("bvh/walking.bvh", 20);
  EXPECT_EQ(reply.format, "bvh");
  EXPECT_EQ(reply.file_frames, 400);
  EXPECT_DOUBLE_EQ(reply.file_frame_rate, 50);
  EXPECT_EQ(reply.last_start, 400 - 299);  // 149 frames at 25 Hz after the start, 298 at 50 Hz
  EXPECT_EQ(reply.motion.layout, "h36m-expmap-99");
  EXPECT_EQ(reply.motion.frames, 150);
  EXPECT_EQ(reply.motion.frame_rate, 25);
  ASSERT_EQ(reply.motion.values.size(), 150u * 99);
  for (int k = 0; k < 150; ++k) {
    for (int c = 0; c < 99; ++c) {
      if (c < 3 && k == 0) {
        // The window's first frame holds where the root is in the file.
        double position = 0;
        for (int f = 0; f <= 10; ++f) position += whole.frame(f)[c];
        ASSERT_NEAR(reply.motion.values[static_cast<size_t>(c)], position, 1e-3) << "column " << c;
        continue;
      }
      ASSERT_EQ(reply.motion.values[static_cast<size_t>(k) * 99 + c], whole.frame(10 + k)[c]) << "frame " << k << " column " << c;
    }
  }
  const auto foreign = read("bvh/Dance.BVH", 0);
  const auto dance = read_bvh_file((data_->root() / "bvh" / "Dance.BVH").string());
  const int columns = 3 + 3 * static_cast<int>(dance.joints.size());
  EXPECT_EQ(foreign.motion.layout, "expmap-" + std::to_string(columns));
  EXPECT_EQ(foreign.motion.columns, columns);
  EXPECT_EQ(foreign.motion.frames, 150);
  EXPECT_NEAR(foreign.file_frame_rate, 120, 1e-3);
  EXPECT_EQ(foreign.file_frames, dance.frame_count());
}

TEST_F(CoreClipsTest, PathsOutsideTheRootMissingOrNotClipsAreRefusedNamingPath) {
  start_with_data_root();
  for (const std::string path : {"../outside.txt", "h36m/../../outside.txt", "/etc/hostname", "link_out.txt",
                                 "folder_link/outside.txt", ""}) {
    const auto error = error_of([&] { read(path, 0); });
    EXPECT_EQ(error.code(), ErrorCode::kInvalidArgument) << path << ": " << error.what();
    EXPECT_EQ(error.field(), "path") << path;
  }
  EXPECT_NE(std::string(error_of([&] { read("../outside.txt", 0); }).what()).find("outside the data root"),
            std::string::npos);
  const auto missing = error_of([&] { read("h36m/S1/walking_9.txt", 0); });
  EXPECT_EQ(missing.code(), ErrorCode::kNotFound);
  EXPECT_EQ(missing.field(), "path");
  for (const std::string path : {"h36m", "README.md"}) {
    EXPECT_EQ(error_of([&] { read(path, 0); }).field(), "path") << path;
  }
  const auto malformed = error_of([&] { read("bad.txt", 0); });
  EXPECT_EQ(malformed.field(), "path");
  EXPECT_NE(std::string(malformed.what()).find("bad.txt:1: expected 99 values"), std::string::npos) << malformed.what();
}

// A NUL would cut the name where the C library reads it: "walking_1.txt\0.bvh"
// was checked as a .bvh and opened as the text file. Every path a client
// names (ReadClip, UploadClip, a job's dataset) goes through the one check.
TEST_F(CoreClipsTest, ControlCharactersInAnyPathAreRefusedNamingTheFieldAndTheByte) {
  start_with_data_root();
  const std::string nul_path("h36m/S1/walking_1.txt\0.bvh", 25);
  const auto read_error = error_of([&] { read(nul_path, 0); });
  EXPECT_EQ(read_error.code(), ErrorCode::kInvalidArgument);
  EXPECT_EQ(read_error.field(), "path");
  EXPECT_NE(std::string(read_error.what()).find("path holds the control character 0x00 at byte 21"), std::string::npos)
      << read_error.what();
  const auto upload_error = error_of([&] { core_->upload_clip(kCall, {"mine/a\nb.txt", "0"}); });
  EXPECT_EQ(upload_error.field(), "path");
  EXPECT_NE(std::string(upload_error.what()).find("control character 0x0A at byte 6"), std::string::npos)
      << upload_error.what();
  EXPECT_FALSE(fs::exists(data_->root() / "mine"));
  const auto dataset_error = error_of([&] { resolve_job_dataset(data_->root().string(), std::string("h36m\0", 5)); });
  EXPECT_EQ(dataset_error.field(), "dataset");
  EXPECT_NE(std::string(dataset_error.what()).find("control character 0x00 at byte 4"), std::string::npos)
      << dataset_error.what();
  // A file on disk whose name holds one is not listed: no client could read it.
  std::ofstream(data_->root() / "tab\tname.txt") << "0\n";
  for (const auto& clip : core_->list_clips(kCall).clips) EXPECT_FALSE(first_control_character(clip.path)) << clip.path;
}

TEST(DataRootPath, EveryControlCharacterIsFoundAndNothingElse) {
  EXPECT_EQ(first_control_character("h36m/S5/walking_1.txt"), std::nullopt);
  EXPECT_EQ(first_control_character("caf\xC3\xA9 walk.bvh"), std::nullopt);  // UTF-8 and spaces are names
  for (int c = 0; c < 0x20; ++c) {
    EXPECT_EQ(first_control_character("ab" + std::string(1, static_cast<char>(c)) + "\x01"), 2u) << c;
  }
  EXPECT_EQ(first_control_character("a\x7F"), 1u);
  test::ScratchDir dir;
  const fs::path root = canonical_data_root(dir.path().string());
  EXPECT_TRUE(resolve_under_data_root(root, "a/b.txt", "path").has_value());
  EXPECT_FALSE(resolve_under_data_root(root, "../b.txt", "path").has_value());
  try {
    resolve_under_data_root(root, "a/\x1B[2Jb.txt", "clip");
    ADD_FAILURE() << "no ApiError";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_EQ(e.field(), "clip");
    EXPECT_EQ(std::string(e.what()), "clip holds the control character 0x1B at byte 2, expected a path of printable characters");
  }
}

TEST_F(CoreClipsTest, AStartPastTheLastFullWindowIsRefusedNamingTheLargestValidStart) {
  start_with_data_root();
  const int64_t rows = read_motion_text((data_->root() / "h36m" / "S5" / "eating_1.txt").string()).frame_count();
  for (const int64_t start : {rows - 299, int64_t{-1}}) {
    const auto error = error_of([&] { read("h36m/S5/eating_1.txt", start); });
    EXPECT_EQ(error.code(), ErrorCode::kInvalidArgument);
    EXPECT_EQ(error.field(), "start");
    EXPECT_NE(std::string(error.what()).find("expected 0 to " + std::to_string(rows - 300)), std::string::npos)
        << error.what();
  }
  const auto bvh = error_of([&] { read("bvh/walking.bvh", 102); });
  EXPECT_EQ(bvh.field(), "start");
  EXPECT_NE(std::string(bvh.what()).find("expected 0 to 101"), std::string::npos) << bvh.what();
}

// An upload is listed and read as the same file put there by hand, in a
// folder the upload creates; only the new file appears (nothing staged is
// left), and the bytes are the ones sent.
TEST_F(CoreClipsTest, AnUploadedFileIsListedAndReadAsTheSameFileOnDisk) {
  start_with_data_root();
  const std::string bvh = test::read_text((test::cmu_dance_dir() / "martial" / "03.bvh").string());
  const std::string text = test::read_text((data_->root() / "h36m" / "S5" / "eating_1.txt").string());
  const ClipFile uploaded = core_->upload_clip(kCall, {"mine/dances/03.bvh", bvh});
  EXPECT_EQ(uploaded.path, "mine/dances/03.bvh");
  EXPECT_EQ(uploaded.format, "bvh");
  EXPECT_EQ(uploaded.size_bytes, static_cast<int64_t>(bvh.size()));
  EXPECT_EQ(test::read_text((data_->root() / "mine" / "dances" / "03.bvh").string()), bvh);
  EXPECT_EQ(core_->upload_clip(kCall, {"mine/S5/eating_1.txt", text}).format, "h36m-text");
  std::vector<std::string> under_mine;
  for (const auto& entry : fs::recursive_directory_iterator(data_->root() / "mine")) {
    if (entry.is_regular_file()) under_mine.push_back(entry.path().lexically_relative(data_->root()).generic_string());
  }
  std::sort(under_mine.begin(), under_mine.end());
  EXPECT_EQ(under_mine, (std::vector<std::string>{"mine/S5/eating_1.txt", "mine/dances/03.bvh"}));
  std::vector<std::string> listed;
  for (const auto& clip : core_->list_clips(kCall).clips) listed.push_back(clip.path);
  EXPECT_NE(std::find(listed.begin(), listed.end(), "mine/dances/03.bvh"), listed.end());
  // Read back as the file it copies.
  EXPECT_EQ(read("mine/S5/eating_1.txt", 10).motion.values, read("h36m/S5/eating_1.txt", 10).motion.values);
}

// Refusals name the field; none of them writes anything, and a file that
// is there is never replaced.
TEST_F(CoreClipsTest, UploadsThatAreBadOrReplaceAFileAreRefusedNamingTheField) {
  start_with_data_root();
  const std::string bvh = test::read_text((test::cmu_dance_dir() / "martial" / "03.bvh").string());
  const std::string before = test::read_text((data_->root() / "h36m" / "S1" / "walking_1.txt").string());
  struct Case {
    UploadClipRequest request;
    ErrorCode code;
    std::string field, says;
  };
  const std::vector<Case> cases{
      {{"", bvh}, ErrorCode::kInvalidArgument, "path", "is empty"},
      {{"/tmp/x.bvh", bvh}, ErrorCode::kInvalidArgument, "path", "is absolute"},
      {{"../outside.bvh", bvh}, ErrorCode::kInvalidArgument, "path", "starting with '.'"},
      {{"mine//x.bvh", bvh}, ErrorCode::kInvalidArgument, "path", "empty component"},
      {{"mine/.hidden.bvh", bvh}, ErrorCode::kInvalidArgument, "path", "starting with '.'"},
      {{"mine/x.obj", bvh}, ErrorCode::kInvalidArgument, "path", "neither extension"},
      // Found by tests/fuzz: the file system refused its temporary name, a 500.
      {{"mine/" + std::string(300, 'a') + ".bvh", bvh}, ErrorCode::kInvalidArgument, "path", "expected at most 128"},
      {{"folder_link/x.bvh", bvh}, ErrorCode::kInvalidArgument, "path", "leads out of the data root"},
      {{"h36m/S1/walking_1.txt", before}, ErrorCode::kFailedPrecondition, "path", "exists already"},
      {{"mine/empty.bvh", ""}, ErrorCode::kInvalidArgument, "content", "empty"},
      {{"mine/bad.bvh", "HIERARCHY\nROOT x\n"}, ErrorCode::kInvalidArgument, "content", "mine/bad.bvh:"},
      {{"mine/bad.txt", "1,2,3\n"}, ErrorCode::kInvalidArgument, "content", "mine/bad.txt:1: expected 99 values"},
  };
  for (const Case& c : cases) {
    const auto error = error_of([&] { core_->upload_clip(kCall, c.request); });
    EXPECT_EQ(error_code_name(error.code()), std::string(error_code_name(c.code))) << c.request.path << ": " << error.what();
    EXPECT_EQ(error.field(), c.field) << c.request.path << ": " << error.what();
    EXPECT_NE(std::string(error.what()).find(c.says), std::string::npos) << c.request.path << ": " << error.what();
  }
  EXPECT_FALSE(fs::exists(data_->root() / "mine"));
  EXPECT_FALSE(fs::exists(data_->root().parent_path() / "outside.bvh"));
  EXPECT_EQ(test::read_text((data_->root() / "h36m" / "S1" / "walking_1.txt").string()), before);
}

TEST_F(CoreClipsTest, AnUploadNeedsTheToken) {
  CoreConfig config;
  config.auth_token = "secret";
  start_with_data_root(config);
  const std::string bvh = test::read_text((test::cmu_dance_dir() / "martial" / "03.bvh").string());
  for (const std::string token : {"", "wrong"}) {
    const auto error = error_of([&] { core_->upload_clip({"test", token}, {"mine/03.bvh", bvh}); });
    EXPECT_EQ(error.code(), ErrorCode::kUnauthenticated) << token;
  }
  EXPECT_FALSE(fs::exists(data_->root() / "mine"));
  EXPECT_EQ(core_->upload_clip({"test", "secret"}, {"mine/03.bvh", bvh}).path, "mine/03.bvh");
}

TEST_F(CoreClipsTest, WithoutADataRootClipsAreAFailedPreconditionNamingTheFlag) {
  start();
  for (const auto& call : std::vector<std::function<void()>>{[&] { core_->list_clips(kCall); },
                                                             [&] { read("h36m/S1/walking_1.txt", 0); },
                                                             [&] { core_->upload_clip(kCall, {"x.txt", "0"}); }}) {
    const auto error = error_of(call);
    EXPECT_EQ(error.code(), ErrorCode::kFailedPrecondition);
    EXPECT_NE(std::string(error.what()).find("without --data-root"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace mm::service
