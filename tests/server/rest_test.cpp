// The REST API as its clients use it: the real server binary on a free
// loopback port, every route exercised with httplib's client, each answer
// checked against the model library's own result for the same input (the
// shipped default model on a real S5 clip), every kind of bad request
// answered with the right status and a JSON error naming the field, and the
// server serving on after each.
#include <arpa/inet.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <ATen/ATen.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <fstream>
#include <future>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "format/foot_contacts.h"
#include "format/motion_text.h"
#include "model/latent_operations.h"
#include "model/motion_manifold.h"
#include "server/rest/rest_routes.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

using json = nlohmann::json;
using test::ServerProcess;

constexpr const char* kToken = "secret";
// The server batches concurrent requests; batched GRU arithmetic differs from
// one clip's in the last bits.
constexpr double kTolerance = 1e-4;

// ---------------------------------------------------------------- reference

const MotionManifold& reference_model() {
  static const MotionManifold model =
      MotionManifold::load(std::string(MM_SOURCE_DIR) + "/models/h36m-dkgm-h100");
  return model;
}

// The first `frames50` frames of an S5 file at its 50 Hz.
MotionFrames s5_file(const std::string& name, int frames50 = 300) {
  MotionFrames all = read_motion_text((test::h36m_dataset_dir() / "S5" / name).string());
  all.values.resize(static_cast<size_t>(frames50) * all.columns);
  return all;
}

// The model's clip: every second frame of the 50 Hz file, as the server and
// the tool take a 50 Hz motion to 25 Hz.
MotionFrames at_25hz(const MotionFrames& motion50) {
  MotionFrames out;
  out.columns = motion50.columns;
  for (int64_t f = 0; f < motion50.frame_count(); f += 2)
    out.values.insert(out.values.end(), motion50.frame(f), motion50.frame(f) + motion50.columns);
  return out;
}

json motion_json(const MotionFrames& motion, double frame_rate) {
  return json{{"frames", motion.frame_count()},
              {"columns", motion.columns},
              {"frame_rate", frame_rate},
              {"layout", "h36m-expmap-99"},
              {"values", motion.values}};
}

std::vector<float> tensor_values(const at::Tensor& t) {
  const at::Tensor c = t.contiguous().to(at::kFloat);
  return std::vector<float>(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
}

at::Tensor codes_tensor(const std::vector<std::vector<float>>& codes) {
  std::vector<float> flat;
  for (const auto& code : codes) flat.insert(flat.end(), code.begin(), code.end());
  return at::from_blob(flat.data(), {static_cast<int64_t>(codes.size()), static_cast<int64_t>(codes[0].size())},
                       at::kFloat)
      .clone();
}

std::vector<float> floats(const json& array) { return array.get<std::vector<float>>(); }

// |a - b| <= tol * (1 + |b|) everywhere: root translations (mm) are large.
void expect_close(const std::vector<float>& actual, const std::vector<float>& expected, const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  double worst = 0;
  size_t worst_index = 0;
  for (size_t i = 0; i < actual.size(); ++i) {
    const double excess = std::fabs(actual[i] - expected[i]) / (1.0 + std::fabs(expected[i]));
    if (excess > worst) worst = excess, worst_index = i;
  }
  EXPECT_LE(worst, kTolerance) << what << ": value " << worst_index << " is " << actual[worst_index]
                               << ", the library's " << expected[worst_index];
}

void expect_codes(const json& codes, const at::Tensor& expected, const std::string& what) {
  ASSERT_TRUE(codes.is_array()) << what;
  ASSERT_EQ(static_cast<int64_t>(codes.size()), expected.size(0)) << what;
  for (size_t i = 0; i < codes.size(); ++i) {
    ASSERT_EQ(codes[i].size(), 64u) << what;
    expect_close(floats(codes[i]), tensor_values(expected[static_cast<int64_t>(i)]),
                 what + " code " + std::to_string(i));
  }
}

void expect_motions(const json& motions, const std::vector<MotionFrames>& expected, const std::string& what) {
  ASSERT_TRUE(motions.is_array()) << what;
  ASSERT_EQ(motions.size(), expected.size()) << what;
  for (size_t i = 0; i < motions.size(); ++i) {
    const json& m = motions[i];
    EXPECT_EQ(m["frames"], 150) << what;
    EXPECT_EQ(m["columns"], 99) << what;
    EXPECT_EQ(m["frame_rate"], 25) << what;
    EXPECT_EQ(m["layout"], "h36m-expmap-99") << what;
    expect_close(floats(m["values"]), expected[i].values, what + " motion " + std::to_string(i));
  }
}

// ---------------------------------------------------------------- HTTP

using test::bearer;
using test::get;
using test::del;
using test::post;
using test::Reply;
using test::to_reply;

httplib::Client client(int port) { return test::rest_client(port); }

// An error reply: the status, the JSON error body's code and field.
void expect_error(const Reply& reply, int status, const std::string& code, const std::string& field) {
  EXPECT_EQ(reply.status, status) << reply.body;
  ASSERT_TRUE(reply.document.is_object() && reply.document.contains("error")) << "not a JSON error: " << reply.body;
  EXPECT_EQ(reply.error()["code"], code) << reply.body;
  EXPECT_EQ(reply.field(), field) << reply.body;
  EXPECT_FALSE(reply.error()["message"].get<std::string>().empty()) << reply.body;
  auto content_type = reply.headers.find("Content-Type");
  ASSERT_NE(content_type, reply.headers.end());
  EXPECT_EQ(content_type->second.rfind("application/json", 0), 0u) << content_type->second;
}

// The server is alive and answers a real call after whatever came before.
void expect_still_serving(int port) {
  EXPECT_EQ(get(port, "/healthz").status, 200);
  const Reply reply = post(port, "/v1/sample", json{{"count", 1}, {"seed", 3}});
  EXPECT_EQ(reply.status, 200) << reply.body;
}

// The sum of every sample of metric `name` whose labels include all of `labels`.
double metric_sum(const std::string& text, const std::string& name, const std::vector<std::string>& labels) {
  double sum = 0;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind(name + "{", 0) != 0 && line.rfind(name + " ", 0) != 0) continue;
    bool all = true;
    for (const auto& label : labels) all = all && line.find(label) != std::string::npos;
    if (all) sum += std::stod(line.substr(line.rfind(' ') + 1));
  }
  return sum;
}

// ---------------------------------------------------------------- fixture

// One server for the suite: the default model, no token.
class RestApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new ServerProcess({"--max-queue-delay-us", "2000"}); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  void SetUp() override { MM_REQUIRE_H36M(); }
  static int port() { return server_->rest_port(); }

  static ServerProcess* server_;
};
ServerProcess* RestApi::server_ = nullptr;

// ---------------------------------------------------------------- operations

TEST_F(RestApi, EncodeGivesTheLibrarysCodesAt50HzAnd25Hz) {
  const MotionFrames walk50 = s5_file("walking_1.txt");
  const MotionFrames walk25 = at_25hz(walk50);
  const at::Tensor expected = encode_motions(reference_model(), {walk25, walk25});

  const Reply reply = post(port(), "/v1/encode",
                           json{{"motions", {motion_json(walk50, 50), motion_json(walk25, 25)}}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.document["answered_by"]["model"], "h36m-dkgm-h100");
  EXPECT_TRUE(std::regex_match(reply.document["answered_by"]["version"].get<std::string>(),
                               std::regex("[0-9a-f]{16}")));
  expect_codes(reply.document["codes"], expected, "encode");
}

TEST_F(RestApi, DecodeGivesTheLibrarysMotionsWithEitherDecoder) {
  const at::Tensor codes = encode_motions(reference_model(), {at_25hz(s5_file("walking_1.txt"))});
  const json wire_codes = json::array({tensor_values(codes[0])});
  for (const char* decoder : {"", "rotation", "velocity"}) {
    const DecoderKind kind =
        std::string(decoder).empty() ? reference_model().default_decoder() : parse_decoder_kind(decoder);
    const Reply reply = post(port(), "/v1/decode", json{{"codes", wire_codes}, {"decoder", decoder}});
    ASSERT_EQ(reply.status, 200) << reply.body;
    expect_motions(reply.document["motions"], decode_codes(reference_model(), codes, kind),
                   std::string("decode ") + decoder);
    EXPECT_TRUE(reply.document["codes"].empty());
  }
}

TEST_F(RestApi, SampleGivesTheLibrarysCodesAndMotionsForASeed) {
  const at::Tensor expected_codes = sample_codes(reference_model(), 3, 7);
  const Reply reply = post(port(), "/v1/sample", json{{"count", 3}, {"seed", 7}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_codes(reply.document["codes"], expected_codes, "sample");
  expect_motions(reply.document["motions"],
                 decode_codes(reference_model(), expected_codes, reference_model().default_decoder()), "sample");
  // proto3's JSON form of a 64-bit integer, a decimal string, is the same seed.
  const Reply again = post(port(), "/v1/sample", json{{"count", 3}, {"seed", "7"}});
  ASSERT_EQ(again.status, 200) << again.body;
  EXPECT_EQ(again.document["codes"], reply.document["codes"]);
}

// The default model has a trajectory network: sampled motions travel in
// world layout (root "generated"), carry a contact bitmask a frame, and
// plant_feet corrects the root only in frames with a planted foot, which
// lowers the skating.
TEST_F(RestApi, SampledMotionsTravelWithContactsAndPlantingTheFeetLowersTheirSkating) {
  const Reply models = get(port(), "/v1/models");
  ASSERT_EQ(models.status, 200) << models.body;
  bool listed = false;
  for (const auto& model : models.document["models"]) {
    if (model["name"] != "h36m-dkgm-h100") continue;
    listed = true;
    EXPECT_EQ(model["trajectory"], true);
    EXPECT_EQ(model["feet"], json::array({"RightFoot", "LeftFoot"}));
  }
  EXPECT_TRUE(listed);

  const Reply plain = post(port(), "/v1/sample", json{{"count", 8}, {"seed", 21}});
  const Reply planted = post(port(), "/v1/sample", json{{"count", 8}, {"seed", 21}, {"plant_feet", true}});
  ASSERT_EQ(plain.status, 200) << plain.body.substr(0, 300);
  ASSERT_EQ(planted.status, 200) << planted.body.substr(0, 300);
  const Skeleton skeleton = Skeleton::h36m();
  SkatingCount before, after;
  double longest_path = 0;
  for (size_t i = 0; i < 8; ++i) {
    const json& a = plain.document["motions"][i];
    const json& b = planted.document["motions"][i];
    EXPECT_EQ(a["root"], "generated");
    ASSERT_EQ(a["contacts"].size(), 150u);
    MotionFrames motion, corrected;
    motion.values = floats(a["values"]);
    corrected.values = floats(b["values"]);
    double path = 0;
    for (int64_t f = 1; f < 150; ++f) path += std::hypot(motion.frame(f)[0], motion.frame(f)[2]);
    longest_path = std::max(longest_path, path);
    const auto contacts = foot_contacts(skeleton, motion, 25);
    for (int64_t f = 0; f < 150; ++f) {
      EXPECT_EQ(a["contacts"][static_cast<size_t>(f)].get<int>(), contacts[static_cast<size_t>(f)]) << "frame " << f;
      // Frames with no planted foot keep their root move; no pose changes.
      if (contacts[static_cast<size_t>(f)] == 0) {
        EXPECT_EQ(corrected.frame(f)[0], motion.frame(f)[0]) << "motion " << i << " frame " << f;
        EXPECT_EQ(corrected.frame(f)[2], motion.frame(f)[2]) << "motion " << i << " frame " << f;
      }
      for (int c = 3; c < 99; ++c) ASSERT_EQ(corrected.frame(f)[c], motion.frame(f)[c]);
    }
    const SkatingCount x = skating_ratio(skeleton, motion, 25), y = skating_ratio(skeleton, corrected, 25);
    before.skating += x.skating, before.frames += x.frames;
    after.skating += y.skating, after.frames += y.frames;
  }
  std::printf("8 samples: longest root path %.0f mm; skating %.3f, with the feet planted %.3f\n", longest_path,
              before.ratio(), after.ratio());
  EXPECT_GT(longest_path, 500.0);
  EXPECT_LT(after.ratio(), before.ratio());
}

TEST_F(RestApi, InterpolateBetweenMotionsAndBetweenCodesGivesTheLibrarysResult) {
  const MotionFrames walk = at_25hz(s5_file("walking_1.txt"));
  const MotionFrames sit = at_25hz(s5_file("sitting_1.txt"));
  const at::Tensor ends = encode_motions(reference_model(), {walk, sit});
  const DecoderKind kind = reference_model().default_decoder();

  const at::Tensor spherical = interpolate_codes(ends[0], ends[1], 5, true);
  Reply reply = post(port(), "/v1/interpolate",
                     json{{"from", {{"motion", motion_json(walk, 25)}}},
                          {"to", {{"motion", motion_json(sit, 25)}}},
                          {"steps", 5},
                          {"method", "spherical"}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_codes(reply.document["codes"], spherical, "interpolate spherical");
  expect_motions(reply.document["motions"], decode_codes(reference_model(), spherical, kind), "interpolate spherical");

  const at::Tensor linear = interpolate_codes(ends[0], ends[1], 3, false);
  reply = post(port(), "/v1/interpolate",
               json{{"from", {{"code", tensor_values(ends[0])}}},
                    {"to", {{"code", tensor_values(ends[1])}}},
                    {"steps", 3},
                    {"method", "linear"},
                    {"decoder", "velocity"}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_codes(reply.document["codes"], linear, "interpolate linear");
  expect_motions(reply.document["motions"], decode_codes(reference_model(), linear, DecoderKind::kVelocity),
                 "interpolate linear");
}

TEST_F(RestApi, AnalogyGivesTheLibrarysResult) {
  const MotionFrames a = at_25hz(s5_file("walkingdog_1.txt"));
  const MotionFrames b = at_25hz(s5_file("walking_1.txt"));
  const MotionFrames c = at_25hz(s5_file("walking_2.txt"));
  const at::Tensor codes = encode_motions(reference_model(), {a, b, c});
  const at::Tensor expected = analogy_code(codes[0], codes[1], codes[2]).reshape({1, -1});

  const Reply reply = post(port(), "/v1/analogy",
                           json{{"a", {{"motion", motion_json(a, 25)}}},
                                {"b", {{"code", tensor_values(codes[1])}}},
                                {"c", {{"motion", motion_json(c, 25)}}}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_codes(reply.document["codes"], expected, "analogy");
  expect_motions(reply.document["motions"],
                 decode_codes(reference_model(), expected, reference_model().default_decoder()), "analogy");
}

TEST_F(RestApi, DenoiseGivesTheLibrarysResultWithItsOptions) {
  const MotionFrames walk = at_25hz(s5_file("walking_1.txt"));
  const MotionFrames noisy =
      corrupt_motion(walk, reference_model().normalization(), 0.5, 1, Corruption::kZeroed);
  const DecoderKind kind = reference_model().default_decoder();

  DenoiseOptions fill;
  fill.zeros_are_missing = true;
  fill.keep_observed = true;
  fill.iterations = 3;
  Reply reply = post(port(), "/v1/denoise",
                     json{{"motions", {motion_json(noisy, 25)}},
                          {"zeros_are_missing", true},
                          {"keep_observed", true},
                          {"iterations", 3}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_motions(reply.document["motions"], denoise_motions(reference_model(), {noisy}, kind, fill), "denoise fill");
  EXPECT_TRUE(reply.document["codes"].empty());

  reply = post(port(), "/v1/denoise", json{{"motions", {motion_json(walk, 25)}}});
  ASSERT_EQ(reply.status, 200) << reply.body;
  expect_motions(reply.document["motions"], denoise_motions(reference_model(), {walk}, kind), "denoise plain");
}

TEST_F(RestApi, ConcurrentCallsAreBatchedAndEachGetsItsOwnAnswer) {
  const std::vector<std::string> files = {"walking_1.txt", "sitting_1.txt", "eating_1.txt", "smoking_1.txt"};
  std::vector<MotionFrames> clips;
  for (const auto& f : files) clips.push_back(at_25hz(s5_file(f)));
  const at::Tensor expected = encode_motions(reference_model(), clips);
  std::vector<std::future<Reply>> replies;
  for (size_t i = 0; i < clips.size(); ++i) {
    const std::string body = json{{"motions", {motion_json(clips[i], 25)}}}.dump();
    replies.push_back(std::async(std::launch::async, [this, body] { return post(port(), "/v1/encode", body); }));
  }
  for (size_t i = 0; i < replies.size(); ++i) {
    const Reply reply = replies[i].get();
    ASSERT_EQ(reply.status, 200) << reply.body;
    expect_codes(reply.document["codes"], expected.slice(0, i, i + 1), files[i]);
  }
}

// ---------------------------------------------------------------- bad requests

TEST_F(RestApi, MotionsOfTheWrongShapeRateOrValuesAreRefusedNamingTheField) {
  const MotionFrames walk50 = s5_file("walking_1.txt");
  const json good = motion_json(walk50, 50);
  auto encode_with = [&](const std::function<void(json&)>& change) {
    json motion = good;
    change(motion);
    return post(port(), "/v1/encode", json{{"motions", {good, motion}}});
  };
  expect_error(encode_with([](json& m) { m["columns"] = 98; }), 400, "INVALID_ARGUMENT", "motions[1].columns");
  expect_error(encode_with([](json& m) { m["frames"] = 299; }), 400, "INVALID_ARGUMENT", "motions[1].frames");
  expect_error(encode_with([](json& m) { m["frame_rate"] = 30; }), 400, "INVALID_ARGUMENT", "motions[1].frame_rate");
  expect_error(encode_with([](json& m) { m["values"].erase(m["values"].size() - 1); }), 400, "INVALID_ARGUMENT",
               "motions[1].values");
  expect_error(encode_with([](json& m) { m["layout"] = "bvh"; }), 400, "INVALID_ARGUMENT", "motions[1].layout");
  // NaN and infinities in proto3's JSON spelling reach the core, which refuses them.
  expect_error(encode_with([](json& m) { m["values"][1000] = "NaN"; }), 400, "INVALID_ARGUMENT",
               "motions[1].values[1000]");
  expect_error(encode_with([](json& m) { m["values"][5] = "-Infinity"; }), 400, "INVALID_ARGUMENT",
               "motions[1].values[5]");
  // Beyond float's range is infinite, and refused the same way.
  expect_error(encode_with([](json& m) { m["values"][7] = 1e300; }), 400, "INVALID_ARGUMENT", "motions[1].values[7]");
  expect_error(post(port(), "/v1/encode", json{{"motions", json::array()}}), 400, "INVALID_ARGUMENT", "motions");
  expect_error(post(port(), "/v1/decode", json{{"codes", {std::vector<float>(63, 0.f)}}}), 400, "INVALID_ARGUMENT",
               "codes[0]");
  expect_error(post(port(), "/v1/interpolate", json{{"from", {{"code", std::vector<float>(64, 0.f)}}},
                                                     {"to", {{"code", std::vector<float>(64, 1.f)}}},
                                                     {"method", "cubic"}}),
               400, "INVALID_ARGUMENT", "method");
  expect_error(post(port(), "/v1/analogy", json{{"a", json::object()}}), 400, "INVALID_ARGUMENT", "a");
  expect_error(post(port(), "/v1/sample", json{{"count", 1}, {"decoder", "spline"}}), 400, "INVALID_ARGUMENT",
               "decoder");
  expect_still_serving(port());
}

TEST_F(RestApi, AnUnknownModelIsNotFound) {
  expect_error(post(port(), "/v1/sample", json{{"model", "no-such-model"}, {"count", 1}}), 404, "NOT_FOUND", "model");
  expect_error(get(port(), "/v1/models/no-such-model"), 404, "NOT_FOUND", "model");
  expect_still_serving(port());
}

TEST_F(RestApi, MalformedJsonIsRefusedWithTheParsersPosition) {
  Reply reply = post(port(), "/v1/encode", std::string(R"({"motions": [ {"frames": 150,, }]})"));
  expect_error(reply, 400, "INVALID_ARGUMENT", "");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("column"), std::string::npos) << reply.body;
  expect_error(post(port(), "/v1/sample", std::string("")), 400, "INVALID_ARGUMENT", "");
  expect_error(post(port(), "/v1/sample", std::string("[1, 2]")), 400, "INVALID_ARGUMENT", "");
  // A number beyond a double's range is malformed JSON too, not an internal error.
  reply = post(port(), "/v1/sample", std::string(R"({"count": 1e400})"));
  expect_error(reply, 400, "INVALID_ARGUMENT", "");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("1e400"), std::string::npos) << reply.body;
  expect_still_serving(port());
}

// Nesting is refused before a body is parsed: printing a deep document (a
// job's configuration) once overflowed a worker's stack and ended the server,
// even on a call without a token.
TEST_F(RestApi, AJsonBodyNestedTooDeeplyIsRefusedAndTheServerServesOn) {
  const std::string deep = "{\"dataset\": \"h36m\", \"config\": {\"a\": " + std::string(150000, '[') +
                           std::string(150000, ']') + "}}";
  const Reply reply = post(port(), "/v1/jobs", deep);
  expect_error(reply, 400, "INVALID_ARGUMENT", "");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("deeper than 64 levels"), std::string::npos) << reply.body;
  expect_still_serving(port());
  // Brackets inside strings are text, not nesting.
  expect_error(post(port(), "/v1/sample", json{{"model", std::string(1000, '[')}, {"count", 1}}), 400,
               "INVALID_ARGUMENT", "model");
}

TEST_F(RestApi, AFieldOfTheWrongJsonTypeIsRefusedNamingItsPathAndType) {
  const json walk = motion_json(at_25hz(s5_file("walking_1.txt")), 25);
  json motion = walk;
  motion["frames"] = "150";
  Reply reply = post(port(), "/v1/encode", json{{"motions", {walk, motion}}});
  expect_error(reply, 400, "INVALID_ARGUMENT", "motions[1].frames");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("integer"), std::string::npos) << reply.body;

  motion = walk;
  motion["values"][17] = true;
  expect_error(post(port(), "/v1/encode", json{{"motions", {motion}}}), 400, "INVALID_ARGUMENT",
               "motions[0].values[17]");
  expect_error(post(port(), "/v1/encode", json{{"motions", walk}}), 400, "INVALID_ARGUMENT", "motions");
  expect_error(post(port(), "/v1/sample", json{{"count", 1.5}}), 400, "INVALID_ARGUMENT", "count");
  expect_error(post(port(), "/v1/sample", json{{"seed", -1}}), 400, "INVALID_ARGUMENT", "seed");
  // Integers exactly: no wrap past 2^64, no blanks, signs or negated strings.
  for (const std::string seed : {"18446744073709551616", "1.8446744073709551616e19", "\" -1\"", "\"-1\"", "\"+5\"",
                                 "\" 5\"", "\"18446744073709551616\""}) {
    expect_error(post(port(), "/v1/sample", "{\"count\": 1, \"seed\": " + seed + "}"), 400, "INVALID_ARGUMENT", "seed");
  }
  EXPECT_EQ(post(port(), "/v1/sample", std::string(R"({"count": 1, "seed": "18446744073709551615"})")).status, 200);
  expect_error(post(port(), "/v1/sample", std::string(R"({"count": 9223372036854775808.0})")), 400, "INVALID_ARGUMENT",
               "count");
  expect_error(post(port(), "/v1/denoise", json{{"motions", {walk}}, {"keep_observed", "yes"}}), 400,
               "INVALID_ARGUMENT", "keep_observed");
  expect_error(post(port(), "/v1/interpolate", json{{"from", {{"code", "zero"}}}}), 400, "INVALID_ARGUMENT",
               "from.code");
  expect_error(post(port(), "/v1/decode", json{{"codes", {{0, 1}, "x"}}}), 400, "INVALID_ARGUMENT", "codes[1]");
  // A misspelt option is an error, not silently the default.
  expect_error(post(port(), "/v1/denoise", json{{"motions", {walk}}, {"zeros_missing", true}}), 400,
               "INVALID_ARGUMENT", "zeros_missing");
  expect_still_serving(port());
}

// Inside nested objects too: a member no message has is refused naming its
// whole path, never dropped (a misspelt "frame_rate" in the second motion
// would otherwise be read as the default rate).
TEST_F(RestApi, AnUnknownMemberInsideANestedObjectIsRefusedNamingItsPath) {
  const json walk = motion_json(at_25hz(s5_file("walking_1.txt")), 25);
  json motion = walk;
  motion["framerate"] = 50;
  Reply reply = post(port(), "/v1/encode", json{{"motions", {walk, motion}}});
  expect_error(reply, 400, "INVALID_ARGUMENT", "motions[1].framerate");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("unknown field"), std::string::npos) << reply.body;

  const std::vector<float> code(64, 0.f);
  expect_error(post(port(), "/v1/interpolate", json{{"from", {{"code", code}, {"weight", 1}}}, {"to", {{"code", code}}}}),
               400, "INVALID_ARGUMENT", "from.weight");
  json from_motion = walk;
  from_motion["root_mode"] = "input";
  expect_error(post(port(), "/v1/interpolate", json{{"from", {{"motion", from_motion}}}, {"to", {{"code", code}}}}),
               400, "INVALID_ARGUMENT", "from.motion.root_mode");
  expect_error(post(port(), "/v1/analogy", json{{"a", {{"code", code}}}, {"b", {{"code", code}}},
                                                {"c", {{"code", code}, {"motion ", walk}}}}),
               400, "INVALID_ARGUMENT", "c.motion ");
  // The same body without the stray member is answered.
  EXPECT_EQ(post(port(), "/v1/encode", json{{"motions", {walk, walk}}}).status, 200);
  expect_still_serving(port());
}

TEST_F(RestApi, AnUnknownRouteIsAJsonNotFound) {
  Reply reply = post(port(), "/v1/encodee", json::object());
  expect_error(reply, 404, "NOT_FOUND", "");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("/v1/encodee"), std::string::npos);
  expect_error(get(port(), "/v1/encode"), 404, "NOT_FOUND", "");  // a route of another method
  expect_error(get(port(), "/v1/models/h36m-dkgm-h100:activate"), 404, "NOT_FOUND", "");
  expect_still_serving(port());
}

TEST(RestLimits, ABodyOverTheLimitIsRefusedAsJsonNamingTheLimitAndTheServerServesOn) {
  MM_REQUIRE_H36M();
  ServerProcess server({"--max-message-bytes", "200000", "--max-motions", "2"});
  const MotionFrames walk50 = s5_file("walking_1.txt");  // 300 x 99 values: about 500 kB of JSON
  const Reply reply = post(server.rest_port(), "/v1/encode", json{{"motions", {motion_json(walk50, 50)}}});
  expect_error(reply, 413, "RESOURCE_EXHAUSTED", "");
  EXPECT_NE(reply.error()["message"].get<std::string>().find("200000"), std::string::npos) << reply.body;
  expect_still_serving(server.rest_port());

  // A chunked body has no Content-Length to check up front: it is cut off at
  // the limit, and the rest is read and dropped so that the client, which
  // sends all of it before it reads, gets the answer. 12 MB is more than the
  // loopback socket buffers hold, so a server that stopped reading at the
  // limit would fail the client's writes every time.
  // As in the project's client: a write to a connection the server closed is
  // a failed call, not the end of the test process.
  std::signal(SIGPIPE, SIG_IGN);
  auto chunked_body = [&](size_t chunks) {
    auto c = client(server.rest_port());
    const std::string chunk = "[" + std::string(99998, ' ') + "]";
    return c.Post(
        "/v1/encode",
        [&, chunks](size_t offset, httplib::DataSink& sink) {
          if (offset >= chunks * chunk.size()) {
            sink.done();
            return true;
          }
          return sink.write(chunk.data(), chunk.size());
        },
        "application/json");
  };
  const Reply chunked_reply = to_reply(chunked_body(120));
  expect_error(chunked_reply, 413, "RESOURCE_EXHAUSTED", "");
  EXPECT_NE(chunked_reply.body.find("200000"), std::string::npos) << chunked_reply.body;
  expect_still_serving(server.rest_port());
  // Past the bound on what is dropped (16 MiB) the connection is given up on;
  // the server serves on.
  const httplib::Result endless = chunked_body(400);
  EXPECT_TRUE(!endless || endless->status == 413) << (endless ? endless->body : std::string());
  expect_still_serving(server.rest_port());

  // The core's own limit on motions of one call (the body is within bounds).
  const json code = std::vector<float>(64, 0.f);
  expect_error(post(server.rest_port(), "/v1/decode", json{{"codes", {code, code, code}}}), 413,
               "RESOURCE_EXHAUSTED", "codes");
  expect_still_serving(server.rest_port());
}

// A request without Content-Length or Transfer-Encoding has no body (RFC 9112,
// 6.3): it is answered at once, not after waiting for the connection to close.
TEST_F(RestApi, APostWithoutContentLengthHasAnEmptyBody) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port()));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  const std::string request = "POST /v1/models/h36m-dkgm-h100:activate HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  ASSERT_EQ(write(fd, request.data(), request.size()), static_cast<ssize_t>(request.size()));
  const auto started = std::chrono::steady_clock::now();
  timeval timeout{20, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  std::string answer;
  char buffer[4096];
  while (answer.find("\r\n\r\n") == std::string::npos) {
    const ssize_t n = read(fd, buffer, sizeof buffer);
    if (n <= 0) break;
    answer.append(buffer, static_cast<size_t>(n));
  }
  close(fd);
  EXPECT_EQ(answer.rfind("HTTP/1.1 200", 0), 0u) << answer;
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(2));
}

// ---------------------------------------------------------------- models and the token

TEST_F(RestApi, ModelsAreListedAndDescribed) {
  const Reply list = get(port(), "/v1/models");
  ASSERT_EQ(list.status, 200) << list.body;
  std::set<std::string> names;
  for (const auto& m : list.document["models"]) names.insert(m["name"].get<std::string>());
  EXPECT_EQ(names, (std::set<std::string>{"h36m-dkgm-cpu", "h36m-dkgm-h100"}));

  const Reply model = get(port(), "/v1/models/h36m-dkgm-h100");
  ASSERT_EQ(model.status, 200) << model.body;
  const json& m = model.document;
  EXPECT_EQ(m["name"], "h36m-dkgm-h100");
  EXPECT_TRUE(m["active"].get<bool>());
  EXPECT_TRUE(m["loaded"].get<bool>());
  EXPECT_EQ(m["variant"], "DKGM");
  EXPECT_EQ(m["hidden"], 1024);
  EXPECT_EQ(m["latent"], 64);
  EXPECT_EQ(m["frames"], 150);
  EXPECT_EQ(m["columns"], 99);
  EXPECT_EQ(m["layout"], "h36m-expmap-99");
  EXPECT_TRUE(m["provenance"].is_object());
  EXPECT_TRUE(m["evaluation"].is_object());
  EXPECT_FALSE(m["evaluation"].empty());
  EXPECT_FALSE(m["model_card"].get<std::string>().empty());
  EXPECT_EQ(m["skeleton"]["name"], "h36m-32");
  EXPECT_EQ(m["skeleton"]["joints"].size(), 32u);
  EXPECT_FALSE(m["skeleton"].contains("bvh"));  // H3.6M's rig came from no BVH file
  for (const auto& listed : list.document["models"]) EXPECT_EQ(listed["skeleton"], json::object());  // describe only
  EXPECT_TRUE(std::regex_match(m["version"].get<std::string>(), std::regex("[0-9a-f]{16}")));
}

TEST(RestAuth, ActivatingAModelNeedsTheTokenAndThenAnswersWithIt) {
  MM_REQUIRE_H36M();
  ServerProcess server({"--auth-token", kToken});
  const int port = server.rest_port();
  for (const httplib::Headers& headers :
       {httplib::Headers{}, bearer("wrong"), httplib::Headers{{"Authorization", std::string("Basic ") + kToken}}}) {
    const Reply reply = post(port, "/v1/models/h36m-dkgm-cpu:activate", std::string(), headers);
    expect_error(reply, 401, "UNAUTHENTICATED", "authorization");
    EXPECT_EQ(reply.headers.count("WWW-Authenticate"), 1u);
    EXPECT_EQ(reply.headers.find("WWW-Authenticate")->second.rfind("Bearer", 0), 0u);
  }
  // Reading needs no token.
  EXPECT_EQ(get(port, "/v1/models").status, 200);
  EXPECT_EQ(post(port, "/v1/sample", json{{"count", 1}}).status, 200);

  const Reply activated = post(port, "/v1/models/h36m-dkgm-cpu:activate", std::string(), bearer(kToken));
  ASSERT_EQ(activated.status, 200) << activated.body;
  EXPECT_EQ(activated.document["name"], "h36m-dkgm-cpu");
  EXPECT_TRUE(activated.document["active"].get<bool>());
  const Reply sample = post(port, "/v1/sample", json{{"count", 1}});
  ASSERT_EQ(sample.status, 200) << sample.body;
  EXPECT_EQ(sample.document["answered_by"]["model"], "h36m-dkgm-cpu");
  // An explicit model overrides the active one.
  const Reply explicit_model = post(port, "/v1/sample", json{{"count", 1}, {"model", "h36m-dkgm-h100"}});
  ASSERT_EQ(explicit_model.status, 200) << explicit_model.body;
  EXPECT_EQ(explicit_model.document["answered_by"]["model"], "h36m-dkgm-h100");

  expect_error(post(port, "/v1/models/missing-model:activate", std::string("{}"), bearer(kToken)), 404, "NOT_FOUND",
               "model");
  expect_error(post(port, "/v1/models/h36m-dkgm-cpu:activate", std::string(R"({"force": true})"), bearer(kToken)), 400,
               "INVALID_ARGUMENT", "force");
  expect_still_serving(port);
}

// ---------------------------------------------------------------- health, metrics, document

TEST_F(RestApi, HealthReadinessAndMetrics) {
  Reply reply = get(port(), "/healthz");
  EXPECT_EQ(reply.status, 200);
  EXPECT_EQ(reply.document["status"], "alive");
  reply = get(port(), "/readyz");
  EXPECT_EQ(reply.status, 200);
  EXPECT_EQ(reply.document["status"], "ready");

  auto metrics = [&] {
    auto c = client(port());
    auto result = c.Get("/metrics");
    EXPECT_TRUE(result);
    EXPECT_EQ(result->status, 200);
    EXPECT_EQ(result->get_header_value("Content-Type").rfind("text/plain", 0), 0u);
    return result->body;
  };
  const std::string before = metrics();
  const std::vector<std::string> ok = {"operation=\"sample\"", "protocol=\"rest\"", "code=\"OK\""};
  const std::vector<std::string> bad = {"operation=\"sample\"", "protocol=\"rest\"", "code=\"INVALID_ARGUMENT\""};
  ASSERT_EQ(post(port(), "/v1/sample", json{{"count", 2}, {"seed", 1}}).status, 200);
  ASSERT_EQ(post(port(), "/v1/sample", json{{"count", 0}}).status, 400);
  const std::string after = metrics();
  EXPECT_EQ(metric_sum(after, "mm_requests_total", ok) - metric_sum(before, "mm_requests_total", ok), 1) << after;
  EXPECT_EQ(metric_sum(after, "mm_requests_total", bad) - metric_sum(before, "mm_requests_total", bad), 1) << after;
  EXPECT_GT(metric_sum(after, "mm_request_duration_seconds_count", {"operation=\"sample\"", "protocol=\"rest\""}),
            metric_sum(before, "mm_request_duration_seconds_count", {"operation=\"sample\"", "protocol=\"rest\""}));
}

TEST_F(RestApi, TheOpenApiDocumentIsServedVerbatim) {
  const Reply reply = get(port(), "/v1/openapi.json");
  ASSERT_EQ(reply.status, 200);
  std::ifstream in(MM_OPENAPI_FILE, std::ios::binary);
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(reply.body, file);
  EXPECT_EQ(reply.document["openapi"], "3.0.3");
}

// Every route the server registers is in the document, and every operation
// the document describes is answered by a route (not the unknown-route 404).
TEST_F(RestApi, EveryRouteIsDocumentedAndEveryDocumentedOperationIsServed) {
  std::ifstream in(MM_OPENAPI_FILE);
  const json document = json::parse(in);
  std::set<std::pair<std::string, std::string>> documented;
  for (const auto& [path, item] : document["paths"].items())
    for (const auto& [method, operation] : item.items()) {
      std::string upper = method;
      for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
      documented.insert({upper, path});
    }
  std::set<std::pair<std::string, std::string>> registered;
  for (const auto& route : service::rest::rest_routes()) registered.insert({route.method, route.path_template});
  EXPECT_EQ(registered, documented);

  for (const auto& [method, path_template] : documented) {
    if (path_template == "/v1/jobs/{id}/events") continue;  // a stream: checked with a job below
    const std::string path = std::regex_replace(path_template, std::regex("\\{[^}]+\\}"), "probe");
    const Reply reply = method == "GET"      ? get(port(), path)
                        : method == "DELETE" ? del(port(), path)
                                             : post(port(), path, std::string("{}"));
    const bool unrouted = reply.status == 404 && reply.document.is_object() &&
                          reply.error()["message"].get<std::string>().rfind("no route", 0) == 0;
    EXPECT_FALSE(unrouted) << method << " " << path << ": " << reply.body;
  }
}

// ---------------------------------------------------------------- jobs

// A data root holding a tiny H3.6M-layout tree (a few S1 and S5 files).
std::filesystem::path tiny_data_root(const std::filesystem::path& scratch) {
  namespace fs = std::filesystem;
  const fs::path root = scratch / "data";
  for (const auto& [subject, files] :
       std::map<std::string, std::vector<std::string>>{{"S1", {"walking_1.txt", "eating_1.txt", "smoking_1.txt"}},
                                                       {"S5", {"walking_1.txt", "eating_1.txt"}}}) {
    fs::create_directories(root / "tiny" / subject);
    for (const auto& file : files) fs::copy_file(test::h36m_dataset_dir() / subject / file, root / "tiny" / subject / file);
  }
  return root;
}

// The events of an SSE stream until it ends: (event name, data) pairs.
std::vector<std::pair<std::string, json>> read_events(int port, const std::string& path, size_t* keep_alives = nullptr) {
  std::vector<std::pair<std::string, json>> events;
  std::string buffer;
  auto c = client(port);
  auto result = c.Get(path.c_str(), [&](const char* data, size_t length) {
    buffer.append(data, length);
    size_t end;
    while ((end = buffer.find("\n\n")) != std::string::npos) {
      const std::string block = buffer.substr(0, end);
      buffer.erase(0, end + 2);
      std::string event, data_line;
      std::istringstream lines(block);
      for (std::string line; std::getline(lines, line);) {
        if (line.rfind("event: ", 0) == 0) event = line.substr(7);
        if (line.rfind("data: ", 0) == 0) data_line = line.substr(6);
        if (line.rfind(":", 0) == 0 && keep_alives) ++*keep_alives;
      }
      if (!event.empty()) events.emplace_back(event, json::parse(data_line));
    }
    return true;
  });
  EXPECT_TRUE(result) << "the event stream broke: " << httplib::to_string(result.error());
  if (result) {
    EXPECT_EQ(result->status, 200);
    EXPECT_EQ(result->get_header_value("Content-Type").rfind("text/event-stream", 0), 0u);
  }
  return events;
}

TEST(RestJobs, ATrainingJobStreamsItsProgressUntilItSucceeds) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  const auto data_root = tiny_data_root(scratch.path());
  ServerProcess server({"--auth-token", kToken, "--data-root", data_root.string(), "--state-dir",
                        (scratch.path() / "state").string()});
  const int port = server.rest_port();
  const json spec = {{"dataset", "tiny"}, {"variant", "D"}, {"iterations", 20}, {"hidden", 16}, {"batch", 4},
                     {"seed", 3}, {"model_name", "rest-tiny"}};
  expect_error(post(port, "/v1/jobs", spec), 401, "UNAUTHENTICATED", "authorization");
  expect_error(post(port, "/v1/jobs", json{{"dataset", "tiny"}, {"config", "{}"}}, bearer(kToken)), 400,
               "INVALID_ARGUMENT", "config");

  const Reply submitted = post(port, "/v1/jobs", spec, bearer(kToken));
  ASSERT_EQ(submitted.status, 200) << submitted.body;
  const std::string id = submitted.document["id"].get<std::string>();
  EXPECT_EQ(submitted.document["spec"]["variant"], "D");
  EXPECT_EQ(submitted.document["spec"]["iterations"], 20);

  const auto events = read_events(port, "/v1/jobs/" + id + "/events");
  ASSERT_FALSE(events.empty());
  int64_t last_iteration = -1;
  for (const auto& [event, job] : events) {
    EXPECT_EQ(event, "job");
    EXPECT_EQ(job["id"], id);
    EXPECT_GE(job["progress"]["iteration"].get<int64_t>(), last_iteration);
    last_iteration = job["progress"]["iteration"].get<int64_t>();
  }
  const json& last = events.back().second;
  ASSERT_EQ(last["state"], "succeeded") << last.dump();
  EXPECT_EQ(last["progress"]["iteration"], 20);
  EXPECT_EQ(last["published_model"], "rest-tiny");

  const Reply job = get(port, "/v1/jobs/" + id);
  ASSERT_EQ(job.status, 200) << job.body;
  EXPECT_EQ(job.document["state"], "succeeded");
  const Reply jobs = get(port, "/v1/jobs");
  ASSERT_EQ(jobs.status, 200);
  ASSERT_EQ(jobs.document["jobs"].size(), 1u);
  EXPECT_EQ(jobs.document["jobs"][0]["id"], id);
  // The stream of a finished job is its final record, once.
  const auto again = read_events(port, "/v1/jobs/" + id + "/events");
  ASSERT_EQ(again.size(), 1u);
  EXPECT_EQ(again[0].second["state"], "succeeded");

  expect_error(post(port, "/v1/jobs/" + id + ":cancel", std::string(), bearer(kToken)), 409, "FAILED_PRECONDITION",
               "id");
  expect_error(get(port, "/v1/jobs/no-such-job"), 404, "NOT_FOUND", "id");
  expect_error(get(port, "/v1/jobs/no-such-job/events"), 404, "NOT_FOUND", "id");
  // The published model is served.
  const Reply sample = post(port, "/v1/sample", json{{"model", "rest-tiny"}, {"count", 1}});
  EXPECT_EQ(sample.status, 200) << sample.body;
}

TEST(RestJobs, ACancelledJobEndsItsStreamAndShutdownEndsOpenStreams) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  const auto data_root = tiny_data_root(scratch.path());
  ServerProcess server({"--data-root", data_root.string(), "--state-dir", (scratch.path() / "state").string()});
  const int port = server.rest_port();
  const json long_job = {{"dataset", "tiny"}, {"variant", "D"}, {"iterations", 100000}, {"hidden", 16}, {"batch", 4}};
  const Reply first = post(port, "/v1/jobs", long_job);
  ASSERT_EQ(first.status, 200) << first.body;
  const std::string id = first.document["id"].get<std::string>();

  auto stream = std::async(std::launch::async, [&] { return read_events(port, "/v1/jobs/" + id + "/events"); });
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const Reply cancelled = post(port, "/v1/jobs/" + id + ":cancel", std::string());
  ASSERT_EQ(cancelled.status, 200) << cancelled.body;
  ASSERT_EQ(stream.wait_for(std::chrono::seconds(60)), std::future_status::ready);
  const auto events = stream.get();
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().second["state"], "cancelled");

  // A stream open on a queued job that never changes ends when the server stops.
  const Reply second = post(port, "/v1/jobs", long_job);
  ASSERT_EQ(second.status, 200) << second.body;
  const Reply third = post(port, "/v1/jobs", long_job);
  ASSERT_EQ(third.status, 200) << third.body;
  size_t keep_alives = 0;
  auto open = std::async(std::launch::async, [&] {
    return read_events(port, "/v1/jobs/" + third.document["id"].get<std::string>() + "/events", &keep_alives);
  });
  std::this_thread::sleep_for(std::chrono::seconds(5));
  EXPECT_GE(keep_alives, 1u);  // an idle stream still writes, to find a client that left
  const auto started = std::chrono::steady_clock::now();
  EXPECT_EQ(server.terminate(), 0) << server.log();
  EXPECT_LT(std::chrono::steady_clock::now() - started, std::chrono::seconds(30));
  ASSERT_EQ(open.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  open.get();
}

// ---------------------------------------------------------------- TLS

TEST(RestTls, WithACertificateAndKeyTheApiIsServedOverHttps) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  const std::string cert = scratch.file("cert.pem"), key = scratch.file("key.pem");
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=127.0.0.1 -keyout " + key +
                              " -out " + cert + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "openssl could not make a test certificate";
  ServerProcess server({"--tls-cert", cert, "--tls-key", key});
  httplib::SSLClient tls("127.0.0.1", server.rest_port());
  tls.enable_server_certificate_verification(false);
  tls.set_read_timeout(120);
  auto result = tls.Post("/v1/sample", json{{"count", 1}, {"seed", 2}}.dump(), "application/json");
  ASSERT_TRUE(result) << httplib::to_string(result.error());
  EXPECT_EQ(result->status, 200) << result->body;
  // Plain HTTP on the TLS port gets no answer.
  auto plain = client(server.rest_port());
  plain.set_read_timeout(5);
  auto refused = plain.Get("/healthz");
  EXPECT_TRUE(!refused || refused->status != 200);
}

}  // namespace
}  // namespace mm
