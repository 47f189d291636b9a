// The gRPC contract, end to end: the real motion-manifold-server binary on
// free loopback ports, called through the generated stubs of
// motionmanifold/v1/manifold.proto. Every answer is checked against the model
// library's own result for the same input (the server batches concurrent
// requests, so values agree to float rounding, not bit for bit), bad requests
// get their status code and a message naming the field, and the server keeps
// serving after them. Health checking, reflection, TLS and shutdown with an
// open stream complete the frontend's specification.
#include <signal.h>

#include <gtest/gtest.h>

#include <google/protobuf/descriptor.pb.h>
#include <grpcpp/grpcpp.h>

#include <ATen/ATen.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "format/motion_text.h"
#include "format/skeleton.h"
#include "model/latent_operations.h"
#include "model/motion_manifold.h"
#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "probes/health_probe.grpc.pb.h"
#include "probes/reflection_probe.grpc.pb.h"
#include "tests/common/test_environment.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using grpc::StatusCode;

constexpr const char* kToken = "secret";
constexpr const char* kDefaultModel = "h36m-dkgm-h100";
constexpr const char* kServiceName = "motionmanifold.v1.MotionManifold";
// The server batches requests: its floats may differ from a lone library
// call's in the last bits, never by more than this.
constexpr double kTolerance = 1e-4;
// --max-message-bytes of the shared server: a few motions fit, 2 M floats do not.
constexpr int kMaxMessageBytes = 4 << 20;

std::string model_dir(const std::string& name) { return std::string(MM_SOURCE_DIR) + "/models/" + name; }

// The library's own model, to compute every expected answer.
const MotionManifold& library_model() {
  static const MotionManifold model = MotionManifold::load(model_dir(kDefaultModel));
  return model;
}

// An S5 file at 50 Hz, as the data set holds it.
const MotionFrames& s5_file(const std::string& name) {
  static std::map<std::string, MotionFrames> files;
  auto found = files.find(name);
  if (found == files.end()) {
    found = files.emplace(name, read_motion_text((test::h36m_dataset_dir() / "S5" / name).string())).first;
  }
  return found->second;
}

// `frames` frames of a file from 50 Hz frame `start`, every `step`-th: step 1
// gives the 50 Hz clip the server takes to 25 Hz, step 2 the 25 Hz clip the
// library takes.
MotionFrames clip(const std::string& name, int frames, int step, int start = 0) {
  const auto& file = s5_file(name);
  MotionFrames out;
  out.columns = file.columns;
  for (int i = 0; i < frames; ++i) {
    const float* row = file.frame(start + i * step);
    out.values.insert(out.values.end(), row, row + file.columns);
  }
  return out;
}

v1::Motion wire_motion(const MotionFrames& frames, double rate) {
  v1::Motion motion;
  motion.set_frames(static_cast<int>(frames.frame_count()));
  motion.set_columns(frames.columns);
  motion.set_frame_rate(rate);
  motion.set_layout("h36m-expmap-99");
  motion.mutable_values()->Add(frames.values.begin(), frames.values.end());
  return motion;
}
// The first 300 frames (6 s at 50 Hz) of an S5 file, as a client sends it.
v1::Motion s5_motion_50hz(const std::string& name, int start = 0) { return wire_motion(clip(name, 300, 1, start), 50); }
// The same window as the library reads it: 150 frames at 25 Hz.
MotionFrames s5_clip_25hz(const std::string& name, int start = 0) { return clip(name, 150, 2, start); }

v1::Code wire_code(const at::Tensor& code) {
  v1::Code out;
  const auto c = code.contiguous().to(at::kFloat);
  out.mutable_values()->Add(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
  return out;
}

double max_difference(const google::protobuf::RepeatedField<float>& got, const float* expected, size_t n) {
  if (static_cast<size_t>(got.size()) != n) return std::numeric_limits<double>::infinity();
  double worst = 0;
  // Relative beyond 1: a generated root path's columns hold positions of
  // hundreds to thousands of mm, where one float's rounding is about 1e-4.
  for (size_t i = 0; i < n; ++i) {
    const double scale = std::max(1.0, std::fabs(static_cast<double>(expected[i])));
    worst = std::max(worst, std::fabs(static_cast<double>(got[i]) - expected[i]) / scale);
  }
  return worst;
}

void expect_code_near(const v1::Code& got, const at::Tensor& expected, const std::string& what) {
  const auto e = expected.contiguous().to(at::kFloat);
  EXPECT_LE(max_difference(got.values(), e.data_ptr<float>(), e.numel()), kTolerance)
      << what << ": " << got.values_size() << " values against " << e.numel();
}

void expect_motion_near(const v1::Motion& got, const MotionFrames& expected, const std::string& what) {
  EXPECT_EQ(got.frames(), expected.frame_count()) << what;
  EXPECT_EQ(got.columns(), expected.columns) << what;
  EXPECT_EQ(got.frame_rate(), 25) << what;
  EXPECT_EQ(got.layout(), "h36m-expmap-99") << what;
  EXPECT_LE(max_difference(got.values(), expected.values.data(), expected.values.size()), kTolerance) << what;
}

// A refusal: its code, a message "<field>: ..." and the field in the
// trailing metadata.
void expect_refused(const grpc::Status& status, const grpc::ClientContext& context, StatusCode code,
                    const std::string& field) {
  EXPECT_EQ(status.error_code(), code) << status.error_message();
  if (field.empty()) return;
  EXPECT_EQ(status.error_message().rfind(field + ": ", 0), 0u)
      << "message does not start with the field \"" << field << "\": " << status.error_message();
  const auto& trailing = context.GetServerTrailingMetadata();
  const auto found = trailing.find("mm-error-field");
  ASSERT_NE(found, trailing.end()) << "no mm-error-field for " << field;
  EXPECT_EQ(std::string(found->second.data(), found->second.size()), field);
}

std::shared_ptr<grpc::Channel> channel_to(const std::string& target,
                                          std::shared_ptr<grpc::ChannelCredentials> credentials = nullptr) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(-1);  // the server's limit is under test, not the client's
  args.SetMaxSendMessageSize(-1);
  return grpc::CreateCustomChannel(target, credentials ? credentials : grpc::InsecureChannelCredentials(), args);
}

void with_deadline(grpc::ClientContext& context, int seconds = 120) {
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
}

void with_token(grpc::ClientContext& context, const std::string& token = kToken) {
  context.AddMetadata("authorization", "Bearer " + token);
}

// A small H3.6M text tree under `root`/h36m (one training file of S1, one
// test file of S5, linked), so that a job prepares its data in a moment.
std::filesystem::path small_data_root(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  for (const auto& [subject, file] : {std::pair{"S1", "walking_1.txt"}, std::pair{"S5", "walking_1.txt"}}) {
    fs::create_directories(root / "h36m" / subject);
    fs::create_symlink(test::h36m_dataset_dir() / subject / file, root / "h36m" / subject / file);
  }
  return root;
}

// A training job that runs long enough to be watched and cancelled: a tiny
// network on the small text tree, far more iterations than a test waits for.
v1::JobSpec long_job_spec() {
  v1::JobSpec spec;
  spec.set_dataset("h36m");
  spec.set_variant("DKGM");
  spec.set_iterations(1000000);
  spec.set_hidden(16);
  spec.set_batch(4);
  spec.set_seed(3);
  return spec;
}

// The shared server's flags: a token, a message limit the tests can exceed,
// and training jobs with their state and data under `scratch`.
std::vector<std::string> server_args(const std::filesystem::path& scratch) {
  return {"--auth-token",
          kToken,
          "--max-message-bytes",
          std::to_string(kMaxMessageBytes),
          "--state-dir",
          (scratch / "state").string(),
          "--data-root",
          small_data_root(scratch / "data").string()};
}

// One server for the suite (its model load is the slow part); tests that
// change its state (the active model) or stop it start their own.
class GrpcApiTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!test::has_h36m()) return;
    scratch_ = new test::ScratchDir();
    // A server that does not start fails every test with its log, rather
    // than the suite's set-up alone (which gtest reports beside skipped tests).
    try {
      server_ = new test::ServerProcess(server_args(scratch_->path()));
      stub_ = v1::MotionManifold::NewStub(channel_to(server_->grpc_target())).release();
    } catch (const std::exception& e) {
      start_error_ = new std::string(e.what());
    }
  }
  static void TearDownTestSuite() {
    delete stub_;
    if (server_) EXPECT_EQ(server_->terminate(), 0) << server_->log();
    delete server_;
    delete scratch_;
    delete start_error_;
    start_error_ = nullptr;
    stub_ = nullptr;
    server_ = nullptr;
    scratch_ = nullptr;
  }
  void SetUp() override {
    MM_REQUIRE_H36M();
    if (start_error_ != nullptr) FAIL() << *start_error_;
  }

  v1::MotionManifold::Stub& stub() { return *stub_; }

  // Encodes a clip through the server and checks it still answers well.
  void expect_still_serving() {
    grpc::ClientContext context;
    with_deadline(context);
    v1::EncodeRequest request;
    *request.add_motions() = s5_motion_50hz("walking_1.txt");
    v1::EncodeReply reply;
    const auto status = stub().Encode(&context, request, &reply);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_EQ(reply.codes_size(), 1);
    expect_code_near(reply.codes(0), encode_motions(library_model(), {s5_clip_25hz("walking_1.txt")})[0],
                     "walking_1 after refusals");
  }

  static test::ScratchDir* scratch_;
  static test::ServerProcess* server_;
  static v1::MotionManifold::Stub* stub_;
  static std::string* start_error_;
};
test::ScratchDir* GrpcApiTest::scratch_ = nullptr;
test::ServerProcess* GrpcApiTest::server_ = nullptr;
v1::MotionManifold::Stub* GrpcApiTest::stub_ = nullptr;
std::string* GrpcApiTest::start_error_ = nullptr;

// ---------------------------------------------------------------------------
// Inference against the library

TEST_F(GrpcApiTest, EncodeOfARealClipMatchesTheLibraryAt50And25Hz) {
  const auto expected = encode_motions(library_model(), {s5_clip_25hz("walking_1.txt")});
  grpc::ClientContext context;
  with_deadline(context);
  v1::EncodeRequest request;
  *request.add_motions() = s5_motion_50hz("walking_1.txt");
  *request.add_motions() = wire_motion(s5_clip_25hz("walking_1.txt"), 25);
  v1::EncodeReply reply;
  const auto status = stub().Encode(&context, request, &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(reply.answered_by().model(), kDefaultModel);
  EXPECT_EQ(reply.answered_by().version().size(), 16u);
  ASSERT_EQ(reply.codes_size(), 2);
  EXPECT_EQ(reply.codes(0).values_size(), library_model().config().latent);
  expect_code_near(reply.codes(0), expected[0], "50 Hz clip");
  expect_code_near(reply.codes(1), expected[0], "the same window at 25 Hz");
}

TEST_F(GrpcApiTest, DecodeMatchesTheLibraryThroughEitherDecoder) {
  const auto codes = encode_motions(library_model(), {s5_clip_25hz("walking_1.txt"), s5_clip_25hz("sitting_1.txt")});
  for (const std::string decoder : {"", "rotation", "velocity"}) {
    const auto kind = decoder == "velocity" ? DecoderKind::kVelocity : DecoderKind::kRotation;
    const auto expected = decode_codes(library_model(), codes, kind);
    grpc::ClientContext context;
    with_deadline(context);
    v1::DecodeRequest request;
    *request.add_codes() = wire_code(codes[0]);
    *request.add_codes() = wire_code(codes[1]);
    request.set_decoder(decoder);
    v1::MotionsReply reply;
    const auto status = stub().Decode(&context, request, &reply);
    ASSERT_TRUE(status.ok()) << decoder << ": " << status.error_message();
    EXPECT_EQ(reply.answered_by().model(), kDefaultModel);
    ASSERT_EQ(reply.motions_size(), 2);
    EXPECT_EQ(reply.codes_size(), 0) << "Decode does not echo the caller's codes";
    for (int i = 0; i < 2; ++i) expect_motion_near(reply.motions(i), expected[i], "decoder '" + decoder + "'");
  }
}

TEST_F(GrpcApiTest, SampleMatchesTheLibraryAndTheSameSeedGivesTheSameMotions) {
  const auto codes = sample_codes(library_model(), 3, 7);
  const auto expected = decode_codes(library_model(), codes, DecoderKind::kRotation);
  v1::SampleRequest request;
  request.set_count(3);
  request.set_seed(7);
  v1::MotionsReply first, second, other_seed;
  {
    grpc::ClientContext context;
    with_deadline(context);
    ASSERT_TRUE(stub().Sample(&context, request, &first).ok());
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    ASSERT_TRUE(stub().Sample(&context, request, &second).ok());
  }
  ASSERT_EQ(first.motions_size(), 3);
  ASSERT_EQ(first.codes_size(), 3);
  for (int i = 0; i < 3; ++i) {
    expect_code_near(first.codes(i), codes[i], "sample code " + std::to_string(i));
    expect_motion_near(first.motions(i), expected[i], "sample motion " + std::to_string(i));
    EXPECT_EQ(first.codes(i).SerializeAsString(), second.codes(i).SerializeAsString()) << "seed 7, twice";
  }
  request.set_seed(8);
  {
    grpc::ClientContext context;
    with_deadline(context);
    ASSERT_TRUE(stub().Sample(&context, request, &other_seed).ok());
  }
  EXPECT_NE(first.codes(0).SerializeAsString(), other_seed.codes(0).SerializeAsString());

  // count left unset (proto3's 0) is the core's default, one motion.
  v1::SampleRequest unset;
  v1::MotionsReply one;
  grpc::ClientContext context;
  with_deadline(context);
  ASSERT_TRUE(stub().Sample(&context, unset, &one).ok());
  EXPECT_EQ(one.motions_size(), 1);
}

TEST_F(GrpcApiTest, InterpolateFromAMotionToACodeMatchesTheLibrary) {
  const auto from = encode_motions(library_model(), {s5_clip_25hz("walking_1.txt")})[0];
  const auto to = sample_codes(library_model(), 1, 11)[0];
  for (const bool spherical : {false, true}) {
    const auto codes = interpolate_codes(from, to, 5, spherical);
    const auto expected = decode_codes(library_model(), codes, DecoderKind::kRotation);
    grpc::ClientContext context;
    with_deadline(context);
    v1::InterpolateRequest request;
    *request.mutable_from()->mutable_motion() = s5_motion_50hz("walking_1.txt");
    *request.mutable_to()->mutable_code() = wire_code(to);
    request.set_steps(5);
    request.set_method(spherical ? "spherical" : "");  // empty: linear
    v1::MotionsReply reply;
    const auto status = stub().Interpolate(&context, request, &reply);
    ASSERT_TRUE(status.ok()) << status.error_message();
    ASSERT_EQ(reply.codes_size(), 5);
    ASSERT_EQ(reply.motions_size(), 5);
    for (int i = 0; i < 5; ++i) {
      const std::string what = std::string(spherical ? "spherical" : "linear") + " step " + std::to_string(i);
      expect_code_near(reply.codes(i), codes[i], what);
      expect_motion_near(reply.motions(i), expected[i], what);
    }
  }
}

TEST_F(GrpcApiTest, AnalogyOfRealClipsMatchesTheLibrary) {
  const auto codes = encode_motions(library_model(), {s5_clip_25hz("walkingdog_1.txt"), s5_clip_25hz("walking_1.txt"),
                                                      s5_clip_25hz("walking_2.txt")});
  const auto code = analogy_code(codes[0], codes[1], codes[2]);
  const auto expected = decode_codes(library_model(), code.unsqueeze(0), DecoderKind::kRotation);
  grpc::ClientContext context;
  with_deadline(context);
  v1::AnalogyRequest request;
  *request.mutable_a()->mutable_motion() = s5_motion_50hz("walkingdog_1.txt");
  *request.mutable_b()->mutable_motion() = s5_motion_50hz("walking_1.txt");
  *request.mutable_c()->mutable_code() = wire_code(codes[2]);
  v1::MotionsReply reply;
  const auto status = stub().Analogy(&context, request, &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(reply.codes_size(), 1);
  ASSERT_EQ(reply.motions_size(), 1);
  expect_code_near(reply.codes(0), code, "a - b + c");
  expect_motion_near(reply.motions(0), expected[0], "analogy motion");
}

TEST_F(GrpcApiTest, DenoiseOfACorruptedClipMatchesTheLibrary) {
  const auto corrupted =
      corrupt_motion(s5_clip_25hz("walking_1.txt"), library_model().normalization(), 0.5, 1, Corruption::kZeroed);
  DenoiseOptions options;
  options.zeros_are_missing = true;
  options.keep_observed = true;
  options.iterations = 3;
  const auto expected = denoise_motions(library_model(), {corrupted}, DecoderKind::kRotation, options);
  grpc::ClientContext context;
  with_deadline(context);
  v1::DenoiseRequest request;
  *request.add_motions() = wire_motion(corrupted, 25);
  request.set_zeros_are_missing(true);
  request.set_keep_observed(true);
  request.set_iterations(3);
  v1::MotionsReply reply;
  const auto status = stub().Denoise(&context, request, &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_EQ(reply.motions_size(), 1);
  EXPECT_EQ(reply.codes_size(), 0);
  expect_motion_near(reply.motions(0), expected[0], "denoised walking_1");
  // The root translation is the input's, not zero.
  EXPECT_FLOAT_EQ(reply.motions(0).values(0), corrupted.values[0]);
}

TEST_F(GrpcApiTest, ConcurrentEncodesAreBatchedAndEachMatchesTheLibrary) {
  constexpr int kClients = 6;
  std::vector<std::future<v1::EncodeReply>> replies;
  for (int i = 0; i < kClients; ++i) {
    replies.push_back(std::async(std::launch::async, [this, i] {
      grpc::ClientContext context;
      with_deadline(context);
      v1::EncodeRequest request;
      *request.add_motions() = s5_motion_50hz("walking_1.txt", 40 * i);
      v1::EncodeReply reply;
      const auto status = stub().Encode(&context, request, &reply);
      EXPECT_TRUE(status.ok()) << status.error_message();
      return reply;
    }));
  }
  for (int i = 0; i < kClients; ++i) {
    const auto reply = replies[i].get();
    ASSERT_EQ(reply.codes_size(), 1);
    expect_code_near(reply.codes(0), encode_motions(library_model(), {s5_clip_25hz("walking_1.txt", 40 * i)})[0],
                     "client " + std::to_string(i));
  }
}

// ---------------------------------------------------------------------------
// Models

TEST_F(GrpcApiTest, ListModelsShowsTheShippedModelsWithTheDefaultActive) {
  grpc::ClientContext context;
  with_deadline(context);
  v1::ListModelsReply reply;
  ASSERT_TRUE(stub().ListModels(&context, v1::ListModelsRequest(), &reply).ok());
  std::map<std::string, v1::ModelInfo> models;
  for (const auto& m : reply.models()) models[m.name()] = m;
  ASSERT_EQ(models.count(kDefaultModel), 1u);
  ASSERT_EQ(models.count("h36m-dkgm-cpu"), 1u);
  const auto& active = models[kDefaultModel];
  EXPECT_TRUE(active.active());
  EXPECT_TRUE(active.loaded());
  EXPECT_FALSE(models["h36m-dkgm-cpu"].active());
  EXPECT_EQ(active.hidden(), library_model().config().hidden);
  EXPECT_EQ(active.latent(), library_model().config().latent);
  EXPECT_EQ(active.frames(), 150);
  EXPECT_EQ(active.columns(), 99);
  EXPECT_EQ(active.frame_rate(), 25);
  EXPECT_EQ(active.layout(), "h36m-expmap-99");
  EXPECT_EQ(active.variant(), "DKGM");
  EXPECT_GT(active.load_seconds(), 0);
  EXPECT_NE(std::find(active.decoders().begin(), active.decoders().end(), "rotation"), active.decoders().end());
}

TEST_F(GrpcApiTest, DescribeModelGivesTheActiveModelsCardAndEvaluation) {
  for (const std::string name : {"", kDefaultModel}) {
    grpc::ClientContext context;
    with_deadline(context);
    v1::DescribeModelRequest request;
    request.set_model(name);
    v1::ModelInfo info;
    const auto status = stub().DescribeModel(&context, request, &info);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(info.name(), kDefaultModel);
    EXPECT_NE(info.model_card().find("h36m"), std::string::npos) << "model card:\n" << info.model_card();
    EXPECT_NE(info.evaluation_json().find("decoders"), std::string::npos);
    EXPECT_EQ(info.provenance_json().front(), '{');
    // The skeleton its motions are in, as a client converts BVH with it.
    EXPECT_EQ(Skeleton::from_json_text(info.skeleton_json(), "skeleton_json").to_json_text(),
              Skeleton::h36m().to_json_text());
  }
  grpc::ClientContext context;
  with_deadline(context);
  v1::DescribeModelRequest request;
  request.set_model("no-such-model");
  v1::ModelInfo info;
  expect_refused(stub().DescribeModel(&context, request, &info), context, StatusCode::NOT_FOUND, "model");
}

// Its own server: activation changes what every later call answers with.
TEST(GrpcModels, ActivateModelNeedsTheTokenAndThenAnswersWithTheNewModel) {
  MM_REQUIRE_H36M();
  test::ServerProcess server({"--auth-token", kToken});
  auto stub = v1::MotionManifold::NewStub(channel_to(server.grpc_target()));
  v1::ActivateModelRequest request;
  request.set_model("h36m-dkgm-cpu");
  for (const std::string token : {"", "wrong"}) {
    grpc::ClientContext context;
    with_deadline(context);
    if (!token.empty()) with_token(context, token);
    v1::ModelInfo info;
    expect_refused(stub->ActivateModel(&context, request, &info), context, StatusCode::UNAUTHENTICATED,
                   "authorization");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    v1::ModelInfo info;
    const auto status = stub->ActivateModel(&context, request, &info);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_EQ(info.name(), "h36m-dkgm-cpu");
    EXPECT_TRUE(info.active());
    EXPECT_TRUE(info.loaded());
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    request.set_model("no-such-model");
    v1::ModelInfo info;
    expect_refused(stub->ActivateModel(&context, request, &info), context, StatusCode::NOT_FOUND, "model");
  }
  // The active model answers, and matches the library's copy of it.
  const auto cpu_model = MotionManifold::load(model_dir("h36m-dkgm-cpu"));
  grpc::ClientContext context;
  with_deadline(context);
  v1::EncodeRequest encode;
  *encode.add_motions() = s5_motion_50hz("walking_1.txt");
  v1::EncodeReply reply;
  ASSERT_TRUE(stub->Encode(&context, encode, &reply).ok());
  EXPECT_EQ(reply.answered_by().model(), "h36m-dkgm-cpu");
  ASSERT_EQ(reply.codes_size(), 1);
  expect_code_near(reply.codes(0), encode_motions(cpu_model, {s5_clip_25hz("walking_1.txt")})[0], "cpu model");
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// ---------------------------------------------------------------------------
// Refusals

TEST_F(GrpcApiTest, MalformedMotionsAreRefusedNamingTheField) {
  struct Case {
    std::string what;
    std::function<void(v1::Motion&)> spoil;
    std::string field;
  };
  const std::vector<Case> cases = {
      {"too few frames", [](v1::Motion& m) { m.set_frames(200); m.mutable_values()->Truncate(200 * 99); },
       "motions[0].frames"},
      {"wrong column count", [](v1::Motion& m) { m.set_columns(98); m.mutable_values()->Truncate(300 * 98); },
       "motions[0].columns"},
      {"unsupported rate", [](v1::Motion& m) { m.set_frame_rate(30); }, "motions[0].frame_rate"},
      {"unknown layout", [](v1::Motion& m) { m.set_layout("bvh"); }, "motions[0].layout"},
      {"values missing", [](v1::Motion& m) { m.mutable_values()->Truncate(1000); }, "motions[0].values"},
      {"NaN value", [](v1::Motion& m) { m.set_values(500, std::nanf("")); }, "motions[0].values[500]"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    grpc::ClientContext context;
    with_deadline(context);
    v1::EncodeRequest request;
    *request.add_motions() = s5_motion_50hz("walking_1.txt");
    c.spoil(*request.mutable_motions(0));
    v1::EncodeReply reply;
    expect_refused(stub().Encode(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, c.field);
  }
  expect_still_serving();
}

TEST_F(GrpcApiTest, BadCodesModelsDecodersAndMethodsAreRefusedNamingTheField) {
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::DecodeRequest request;
    request.add_codes()->mutable_values()->Resize(10, 0.0f);
    v1::MotionsReply reply;
    expect_refused(stub().Decode(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, "codes[0]");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::DecodeRequest request;
    *request.add_codes() = wire_code(sample_codes(library_model(), 1, 1)[0]);
    request.set_model("no-such-model");
    v1::MotionsReply reply;
    expect_refused(stub().Decode(&context, request, &reply), context, StatusCode::NOT_FOUND, "model");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::SampleRequest request;
    request.set_decoder("diffusion");
    v1::MotionsReply reply;
    expect_refused(stub().Sample(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, "decoder");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::SampleRequest request;
    request.set_count(1000);
    v1::MotionsReply reply;
    expect_refused(stub().Sample(&context, request, &reply), context, StatusCode::RESOURCE_EXHAUSTED, "count");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::InterpolateRequest request;
    *request.mutable_from()->mutable_code() = wire_code(sample_codes(library_model(), 1, 1)[0]);
    *request.mutable_to()->mutable_code() = wire_code(sample_codes(library_model(), 1, 2)[0]);
    request.set_method("cubic");
    v1::MotionsReply reply;
    expect_refused(stub().Interpolate(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, "method");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::InterpolateRequest request;  // neither motion nor code
    *request.mutable_to()->mutable_code() = wire_code(sample_codes(library_model(), 1, 2)[0]);
    v1::MotionsReply reply;
    expect_refused(stub().Interpolate(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, "from");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::AnalogyRequest request;
    *request.mutable_a()->mutable_code() = wire_code(sample_codes(library_model(), 1, 1)[0]);
    *request.mutable_b()->mutable_code() = wire_code(sample_codes(library_model(), 1, 2)[0]);
    request.mutable_c()->mutable_code()->add_values(1.0f);
    v1::MotionsReply reply;
    expect_refused(stub().Analogy(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT, "c.code");
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::DenoiseRequest request;
    *request.add_motions() = s5_motion_50hz("walking_1.txt");
    request.set_zeros_are_missing(true);
    request.set_means_are_missing(true);
    v1::MotionsReply reply;
    expect_refused(stub().Denoise(&context, request, &reply), context, StatusCode::INVALID_ARGUMENT,
                   "means_are_missing");
  }
  expect_still_serving();
}

TEST_F(GrpcApiTest, AMessageLargerThanTheLimitIsRefusedBeforeTheCore) {
  grpc::ClientContext context;
  with_deadline(context);
  v1::EncodeRequest request;
  auto* motion = request.add_motions();
  *motion = s5_motion_50hz("walking_1.txt");
  motion->mutable_values()->Resize(kMaxMessageBytes / 4 + 1000, 0.0f);
  v1::EncodeReply reply;
  const auto status = stub().Encode(&context, request, &reply);
  EXPECT_EQ(status.error_code(), StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  expect_still_serving();
}

// ---------------------------------------------------------------------------
// Training jobs

TEST_F(GrpcApiTest, JobCallsThatChangeStateNeedTheToken) {
  for (const std::string token : {"", "wrong"}) {
    SCOPED_TRACE("token '" + token + "'");
    {
      grpc::ClientContext context;
      with_deadline(context);
      if (!token.empty()) with_token(context, token);
      v1::SubmitJobRequest request;
      *request.mutable_spec() = long_job_spec();
      v1::Job job;
      expect_refused(stub().SubmitJob(&context, request, &job), context, StatusCode::UNAUTHENTICATED,
                     "authorization");
    }
    {
      grpc::ClientContext context;
      with_deadline(context);
      if (!token.empty()) with_token(context, token);
      v1::CancelJobRequest request;
      request.set_id("1");
      v1::Job job;
      expect_refused(stub().CancelJob(&context, request, &job), context, StatusCode::UNAUTHENTICATED,
                     "authorization");
    }
  }
  grpc::ClientContext context;
  with_deadline(context);
  v1::GetJobRequest request;
  request.set_id("no-such-job");
  v1::Job job;
  EXPECT_EQ(stub().GetJob(&context, request, &job).error_code(), StatusCode::NOT_FOUND);
  expect_still_serving();
}

TEST_F(GrpcApiTest, WatchJobStreamsProgressUntilTheJobIsCancelled) {
  v1::Job submitted;
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    v1::SubmitJobRequest request;
    *request.mutable_spec() = long_job_spec();
    const auto status = stub().SubmitJob(&context, request, &submitted);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_FALSE(submitted.id().empty());
  EXPECT_TRUE(submitted.state() == "queued" || submitted.state() == "running") << submitted.state();
  EXPECT_EQ(submitted.spec().hidden(), 16);
  EXPECT_EQ(submitted.spec().iterations(), 1000000);
  EXPECT_GT(submitted.created_at(), 1.6e9);

  grpc::ClientContext watch_context;
  with_deadline(watch_context, 300);
  v1::WatchJobRequest watch;
  watch.set_id(submitted.id());
  auto reader = stub().WatchJob(&watch_context, watch);
  v1::Job event;
  ASSERT_TRUE(reader->Read(&event)) << "no first record";
  EXPECT_EQ(event.id(), submitted.id());

  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::GetJobRequest request;
    request.set_id(submitted.id());
    v1::Job job;
    ASSERT_TRUE(stub().GetJob(&context, request, &job).ok());
    EXPECT_EQ(job.spec().SerializeAsString(), submitted.spec().SerializeAsString());
  }
  {
    grpc::ClientContext context;
    with_deadline(context);
    v1::ListJobsReply jobs;
    ASSERT_TRUE(stub().ListJobs(&context, v1::ListJobsRequest(), &jobs).ok());
    ASSERT_GE(jobs.jobs_size(), 1);
    EXPECT_EQ(jobs.jobs(0).id(), submitted.id()) << "newest first";
  }
  // The stream carries the training's progress: every loss term, by name.
  while (event.progress().iteration() == 0 && reader->Read(&event)) {
    ASSERT_FALSE(event.state() == "failed") << event.error();
  }
  EXPECT_EQ(event.state(), "running");
  EXPECT_GT(event.progress().iteration(), 0);
  EXPECT_EQ(event.progress().total(), 1000000);
  EXPECT_GT(event.progress().losses().size(), 0u);
  EXPECT_GT(event.started_at(), 0);
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    v1::CancelJobRequest request;
    request.set_id(submitted.id());
    v1::Job job;
    const auto status = stub().CancelJob(&context, request, &job);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  std::string last_state = event.state();
  while (reader->Read(&event)) last_state = event.state();
  const auto status = reader->Finish();
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(last_state, "cancelled");
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    v1::CancelJobRequest request;
    request.set_id(submitted.id());
    v1::Job job;
    EXPECT_EQ(stub().CancelJob(&context, request, &job).error_code(), StatusCode::FAILED_PRECONDITION)
        << "a finished job cannot be cancelled again";
  }
}

// ---------------------------------------------------------------------------
// Standard services

TEST_F(GrpcApiTest, HealthCheckReportsServingForTheServerAndTheService) {
  auto health = grpc::health::v1::Health::NewStub(channel_to(server_->grpc_target()));
  for (const std::string service : {"", kServiceName}) {
    grpc::ClientContext context;
    with_deadline(context);
    grpc::health::v1::HealthCheckRequest request;
    request.set_service(service);
    grpc::health::v1::HealthCheckResponse response;
    const auto status = health->Check(&context, request, &response);
    ASSERT_TRUE(status.ok()) << "'" << service << "': " << status.error_message();
    EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING) << "'" << service << "'";
  }
  grpc::ClientContext context;
  with_deadline(context);
  grpc::health::v1::HealthCheckRequest request;
  request.set_service("no.such.Service");
  grpc::health::v1::HealthCheckResponse response;
  EXPECT_EQ(health->Check(&context, request, &response).error_code(), StatusCode::NOT_FOUND);
}

TEST_F(GrpcApiTest, ReflectionListsTheServiceAndServesItsDescriptor) {
  namespace reflection = grpc::reflection::v1alpha;
  auto stub = reflection::ServerReflection::NewStub(channel_to(server_->grpc_target()));
  grpc::ClientContext context;
  with_deadline(context);
  auto stream = stub->ServerReflectionInfo(&context);

  reflection::ServerReflectionRequest list;
  list.set_list_services("");
  ASSERT_TRUE(stream->Write(list));
  reflection::ServerReflectionResponse listed;
  ASSERT_TRUE(stream->Read(&listed));
  std::vector<std::string> services;
  for (const auto& s : listed.list_services_response().service()) services.push_back(s.name());
  for (const char* expected : {kServiceName, "grpc.health.v1.Health", "grpc.reflection.v1alpha.ServerReflection"}) {
    EXPECT_NE(std::find(services.begin(), services.end(), expected), services.end()) << expected;
  }

  reflection::ServerReflectionRequest symbol;
  symbol.set_file_containing_symbol(kServiceName);
  ASSERT_TRUE(stream->Write(symbol));
  reflection::ServerReflectionResponse described;
  ASSERT_TRUE(stream->Read(&described));
  ASSERT_TRUE(described.has_file_descriptor_response()) << described.error_response().error_message();
  ASSERT_GE(described.file_descriptor_response().file_descriptor_proto_size(), 1);
  google::protobuf::FileDescriptorProto file;
  ASSERT_TRUE(file.ParseFromString(described.file_descriptor_response().file_descriptor_proto(0)));
  EXPECT_EQ(file.name(), "motionmanifold/v1/manifold.proto");
  EXPECT_EQ(file.package(), "motionmanifold.v1");
  ASSERT_EQ(file.service_size(), 1);
  std::vector<std::string> methods;
  for (const auto& m : file.service(0).method()) {
    methods.push_back(m.name());
    const std::set<std::string> replies_streamed = {"WatchJob", "ReconstructTake", "DenoiseTake", "DecodeTrack"};
    const std::set<std::string> requests_streamed = {"EncodeTake", "ReconstructTake", "DenoiseTake"};
    EXPECT_EQ(m.server_streaming(), replies_streamed.count(m.name()) == 1) << m.name();
    EXPECT_EQ(m.client_streaming(), requests_streamed.count(m.name()) == 1) << m.name();
  }
  EXPECT_EQ(methods, (std::vector<std::string>{"Encode", "Decode", "Sample", "Interpolate", "Analogy", "Denoise",
                                               "JoinClips", "ListModels", "DescribeModel", "ActivateModel", "DeleteModel",
                                               "ListClips", "ReadClip", "UploadClip", "DeleteClip", "SubmitJob",
                                               "GetJob", "ListJobs", "CancelJob", "DeleteJob", "WatchJob",
                                               "EncodeTake", "ReconstructTake", "DenoiseTake", "DecodeTrack"}));
  stream->WritesDone();
  EXPECT_TRUE(stream->Finish().ok());
}

// ---------------------------------------------------------------------------
// Transport and lifecycle

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

TEST(GrpcTransport, TlsServesOnlyClientsThatSpeakTls) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  const std::string cert = dir.file("cert.pem"), key = dir.file("key.pem");
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=localhost "
                              "-addext subjectAltName=IP:127.0.0.1,DNS:localhost -keyout " +
                              key + " -out " + cert + " >/dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "openssl could not make a test certificate";
  test::ServerProcess server({"--tls-cert", cert, "--tls-key", key});

  grpc::SslCredentialsOptions trust;
  trust.pem_root_certs = read_file(cert);
  auto secure = v1::MotionManifold::NewStub(channel_to(server.grpc_target(), grpc::SslCredentials(trust)));
  {
    grpc::ClientContext context;
    with_deadline(context, 30);
    v1::ListModelsReply reply;
    const auto status = secure->ListModels(&context, v1::ListModelsRequest(), &reply);
    ASSERT_TRUE(status.ok()) << status.error_message();
    EXPECT_GE(reply.models_size(), 2);
  }
  auto plain = v1::MotionManifold::NewStub(channel_to(server.grpc_target()));
  grpc::ClientContext context;
  with_deadline(context, 10);
  v1::ListModelsReply reply;
  EXPECT_EQ(plain->ListModels(&context, v1::ListModelsRequest(), &reply).error_code(), StatusCode::UNAVAILABLE);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

TEST(GrpcLifecycle, SigtermEndsAnOpenWatchStreamAndTheServerExitsCleanly) {
  MM_REQUIRE_H36M();
  test::ScratchDir dir;
  test::ServerProcess server(server_args(dir.path()));
  auto stub = v1::MotionManifold::NewStub(channel_to(server.grpc_target()));
  v1::Job submitted;
  {
    grpc::ClientContext context;
    with_deadline(context);
    with_token(context);
    v1::SubmitJobRequest request;
    *request.mutable_spec() = long_job_spec();
    const auto status = stub->SubmitJob(&context, request, &submitted);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  grpc::ClientContext watch_context;
  with_deadline(watch_context, 300);
  v1::WatchJobRequest watch;
  watch.set_id(submitted.id());
  auto reader = stub->WatchJob(&watch_context, watch);
  v1::Job event;
  ASSERT_TRUE(reader->Read(&event));

  // The stream must not hold the shutdown up until gRPC's deadline (10 s in
  // main.cpp) cancels it: the frontend ends it as soon as it stops, and says
  // why, so that the client watches again after the restart.
  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(::kill(server.pid(), SIGTERM), 0);
  while (reader->Read(&event)) {
  }
  const auto status = reader->Finish();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(status.error_code(), StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_LT(seconds, 5.0) << "the stream outlived the shutdown";
  std::cout << "SIGTERM to the end of an open WatchJob stream: " << seconds << " s\n";
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

}  // namespace
}  // namespace mm
