// motion-manifold-client end to end, as a user runs it: the real client
// binary against the real server (tests/server/server_process.h) on
// loopback, every command, its files and its JSON checked against what the
// server itself answers, and each command's refusal with its exit status
// (1: the server refused, 2: bad local input) and the server's message.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/client/client_files.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* const kToken = "client-token";

using Run = test::CommandRun;
using test::motion_rows;
using test::read_text;
using test::run_client;
using test::s5;

// The small H3.6M text tree of tests/server: S1 to train on, S5 to test.
// Copies, not links: a link out of the data root is not one of its clips.
fs::path small_data_root(const fs::path& scratch) {
  const fs::path root = scratch / "data";
  for (const auto& [subject, files] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"S1", {"walking_1.txt", "walking_2.txt", "eating_1.txt"}}, {"S5", {"walking_1.txt"}}}) {
    fs::create_directories(root / "small" / subject);
    for (const auto& file : files) {
      fs::copy_file(test::h36m_dataset_dir() / subject / file, root / "small" / subject / file);
    }
  }
  return root;
}

std::vector<std::string> job_server_args(const fs::path& scratch) {
  return {"--auth-token", kToken, "--state-dir", (scratch / "state").string(), "--data-root",
          small_data_root(scratch).string(), "--checkpoint-every", "5"};
}

// One server for the suite: loading the models is the slow part.
class ClientTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!test::has_h36m()) return;
    scratch_ = new test::ScratchDir();
    server_ = new test::ServerProcess(job_server_args(scratch_->path()));
  }
  static void TearDownTestSuite() {
    delete server_;
    delete scratch_;
    server_ = nullptr;
    scratch_ = nullptr;
  }
  void SetUp() override {
    MM_REQUIRE_H36M();
    ASSERT_NE(server_, nullptr);
  }

  static std::string grpc() { return "--server " + server_->grpc_target(); }
  static std::string rest() { return "--rest --rest-url " + server_->rest_url(); }
  static std::string token() { return std::string("--token ") + kToken; }

  // The server's own answer over REST, for comparing.
  static json rest_call(const std::string& path, const json& body) {
    return test::rest_call(server_->rest_port(), kToken, "POST", path, body);
  }

  static test::ServerProcess* server_;
  static test::ScratchDir* scratch_;
  test::ScratchDir dir_;
};

test::ServerProcess* ClientTest::server_ = nullptr;
test::ScratchDir* ClientTest::scratch_ = nullptr;

// encode's code file: {"codes": [[...]], "model"}, a REST Decode body as it is.
std::vector<double> code_of(const std::string& out) {
  const json codes = json::parse(out).at("codes");
  EXPECT_EQ(codes.size(), 1u) << out;
  return codes.at(0).get<std::vector<double>>();
}

// The first 300 frames (6 s at 50 Hz) of an H3.6M file, as a REST motion.
json rest_motion(const std::string& path) {
  auto rows = motion_rows(path);
  std::vector<double> values;
  for (int i = 0; i < 300; ++i) values.insert(values.end(), rows[i].begin(), rows[i].end());
  return {{"frames", 300}, {"columns", 99}, {"frame_rate", 50}, {"layout", "h36m-expmap-99"}, {"values", values}};
}

// ---------------------------------------------------------------- encode

TEST_F(ClientTest, EncodeGivesTheServersCodeOverBothProtocols) {
  const auto expected = rest_call("/v1/encode", {{"motions", {rest_motion(s5("walking_1.txt"))}}});
  const auto want = expected["codes"][0].get<std::vector<double>>();
  ASSERT_EQ(want.size(), 64u);
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " encode --input " + s5("walking_1.txt"));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto code = code_of(run.out);
    ASSERT_EQ(code.size(), 64u);
    for (size_t i = 0; i < code.size(); ++i) EXPECT_NEAR(code[i], want[i], 1e-5) << i;
    EXPECT_EQ(json::parse(run.out)["model"], expected["answered_by"]["model"]);
    // One code file for the client, the tool and REST: encode's output is a
    // REST Decode body as it is.
    const json decoded = rest_call("/v1/decode", json::parse(run.out));
    ASSERT_EQ(decoded["motions"].size(), 1u) << decoded.dump();
    EXPECT_EQ(decoded["motions"][0]["frames"], 150);
  }
  // --json prints the reply itself, as REST does.
  const auto run = run_client(grpc() + " --json encode --input " + s5("walking_1.txt"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(json::parse(run.out)["answered_by"], expected["answered_by"]);
  EXPECT_EQ(json::parse(run.out)["codes"][0].size(), 64u);
}

TEST_F(ClientTest, EncodeRefusesBadFilesLocallyAndBadModelsAsTheServerSays) {
  auto run = run_client(grpc() + " encode --input " + dir_.file("missing.txt"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("missing.txt: cannot open the file"), std::string::npos) << run.err;

  run = run_client(grpc() + " encode --input " + dir_.write("walk.bvh", "HIERARCHY\n"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("walk.bvh:"), std::string::npos) << run.err;

  run = run_client(grpc() + " encode --input " + dir_.write("short.txt", "1,2,3\n"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("short.txt:1"), std::string::npos) << run.err;

  for (const auto& protocol : {grpc(), rest()}) {
    run = run_client(protocol + " encode --model no-such-model --input " + s5("walking_1.txt"));
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_EQ(run.err.rfind("error: NOT_FOUND: model: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("no-such-model"), std::string::npos) << run.err;
  }
}

TEST_F(ClientTest, AnUnreachableServerIsExitOne) {
  const auto run = run_client("--server 127.0.0.1:1 encode --input " + s5("walking_1.txt"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: UNAVAILABLE: ", 0), 0u) << run.err;
}

TEST_F(ClientTest, UsageErrorsAreExitTwo) {
  EXPECT_EQ(run_client("").exit_code, 2);
  EXPECT_EQ(run_client("encode").exit_code, 2);  // --input is required
  EXPECT_EQ(run_client("encode --input x.txt --rate 30").exit_code, 2);
  EXPECT_EQ(run_client("sample --seed 1").exit_code, 2);  // neither --out-dir nor --json
}

// ---------------------------------------------------------------- decode

TEST_F(ClientTest, DecodeWritesA150FrameMotionFromAnEncodedCode) {
  for (const auto& protocol : {grpc(), rest()}) {
    const auto encoded = run_client(protocol + " encode --input " + s5("walking_1.txt"));
    ASSERT_EQ(encoded.exit_code, 0) << encoded.err;
    const auto code_file = dir_.write("code.json", encoded.out);
    const auto out = dir_.file("decoded.txt");
    const auto run = run_client(protocol + " decode --code " + code_file + " --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto rows = motion_rows(out);
    ASSERT_EQ(rows.size(), 150u);
    for (const auto& row : rows) ASSERT_EQ(row.size(), 99u);
    // Read back at 25 Hz, the decoded motion encodes again.
    const auto again = run_client(protocol + " encode --rate 25 --input " + out);
    EXPECT_EQ(again.exit_code, 0) << again.err;
  }
}

TEST_F(ClientTest, ABvhWrittenByDecodeEncodesToTheSameCodeAsItsText) {
  const auto encoded = run_client(grpc() + " encode --input " + s5("walking_1.txt"));
  ASSERT_EQ(encoded.exit_code, 0) << encoded.err;
  const auto code_file = dir_.write("code.json", encoded.out);
  const auto text = dir_.file("decoded.txt"), bvh = dir_.file("decoded.bvh");
  ASSERT_EQ(run_client(grpc() + " decode --code " + code_file + " --out " + text).exit_code, 0);
  const auto written = run_client(grpc() + " decode --code " + code_file + " --out " + bvh);
  ASSERT_EQ(written.exit_code, 0) << written.err;
  std::ifstream in(bvh);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first.rfind("HIERARCHY", 0), 0u) << first;
  const auto from_text = run_client(rest() + " --json encode --rate 25 --input " + text);
  const auto from_bvh = run_client(rest() + " --json encode --input " + bvh);
  ASSERT_EQ(from_text.exit_code, 0) << from_text.err;
  ASSERT_EQ(from_bvh.exit_code, 0) << from_bvh.err;
  const auto a = json::parse(from_text.out)["codes"][0], b = json::parse(from_bvh.out)["codes"][0];
  ASSERT_EQ(a.size(), 64u);
  ASSERT_EQ(b.size(), 64u);
  for (size_t i = 0; i < 64; ++i) EXPECT_NEAR(a[i].get<double>(), b[i].get<double>(), 1e-3) << i;
}

TEST_F(ClientTest, DecodeOfACodeOfTheWrongLengthNamesTheField) {
  const auto code_file = dir_.write("short.json", "[0.1, 0.2, 0.3]");
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " decode --code " + code_file + " --out " + dir_.file("x.txt"));
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: codes[0]", 0), 0u) << run.err;
  }
  const auto run = run_client(grpc() + " decode --code " + dir_.write("bad.json", "{\"code\": [1, \"a\"]}") +
                              " --out " + dir_.file("x.txt"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("code[1]"), std::string::npos) << run.err;
}

// ---------------------------------------------------------------- sample

TEST_F(ClientTest, SampleWithASeedIsReproducible) {
  const auto a = dir_.file("a"), b = dir_.file("b"), c = dir_.file("c");
  auto run = run_client(grpc() + " sample --count 2 --seed 7 --out-dir " + a);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, a + "/sample_000.txt\n" + a + "/sample_001.txt\n");
  ASSERT_EQ(run_client(rest() + " sample --count 2 --seed 7 --out-dir " + b).exit_code, 0);
  ASSERT_EQ(run_client(grpc() + " sample --count 2 --seed 8 --out-dir " + c).exit_code, 0);
  for (const char* file : {"/sample_000.txt", "/sample_001.txt"}) {
    EXPECT_EQ(motion_rows(a + file).size(), 150u);
    EXPECT_EQ(read_text(a + file), read_text(b + file)) << file;
    EXPECT_NE(read_text(a + file), read_text(c + file)) << file;
  }
  EXPECT_FALSE(fs::exists(a + "/sample_002.txt"));
}

TEST_F(ClientTest, SampleRefusesAnUnknownDecoder) {
  const auto run = run_client(grpc() + " sample --decoder sideways --out-dir " + dir_.file("s"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: decoder: ", 0), 0u) << run.err;
  EXPECT_NE(run.err.find("sideways"), std::string::npos) << run.err;
}

// ----------------------------------------------------------- interpolate

TEST_F(ClientTest, InterpolateWritesOneFilePerStep) {
  const auto out = dir_.file("interp");
  const auto run = run_client(grpc() + " interpolate --from " + s5("walking_1.txt") + " --to " + s5("eating_1.txt") +
                              " --steps 5 --spherical --out-dir " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(motion_rows(out + "/interpolation_00" + std::to_string(i) + ".txt").size(), 150u) << i;
  }
  EXPECT_FALSE(fs::exists(out + "/interpolation_005.txt"));
  // A code file is an end too; --json prints the codes.
  const auto encoded = run_client(grpc() + " encode --input " + s5("walking_1.txt"));
  const auto code_file = dir_.write("walk.json", encoded.out);
  const auto json_run = run_client(rest() + " --json interpolate --from " + code_file + " --to " + s5("eating_1.txt") +
                                   " --steps 3");
  ASSERT_EQ(json_run.exit_code, 0) << json_run.err;
  const auto reply = json::parse(json_run.out);
  ASSERT_EQ(reply["codes"].size(), 3u);
  const auto first = reply["codes"][0].get<std::vector<double>>();
  const auto code = code_of(encoded.out);
  for (size_t i = 0; i < code.size(); ++i) EXPECT_NEAR(first[i], code[i], 1e-5);
}

// The tool's names: --format and interpolation_000.<format>.
TEST_F(ClientTest, InterpolateWritesBvhFilesWithFormatBvh) {
  const auto out = dir_.file("interp-bvh");
  const auto run = run_client(rest() + " interpolate --from " + s5("walking_1.txt") + " --to " + s5("eating_1.txt") +
                              " --steps 2 --format bvh --out-dir " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, out + "/interpolation_000.bvh\n" + out + "/interpolation_001.bvh\n");
  EXPECT_EQ(read_text(out + "/interpolation_001.bvh").rfind("HIERARCHY", 0), 0u);
}

TEST_F(ClientTest, InterpolateRefusesAnUnknownMethod) {
  const auto run = run_client(grpc() + " interpolate --from " + s5("walking_1.txt") + " --to " + s5("walking_1.txt") +
                              " --method cubic --out-dir " + dir_.file("i"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: method: ", 0), 0u) << run.err;
}

// ---------------------------------------------------------------- analogy

TEST_F(ClientTest, AnalogyWritesOneMotion) {
  const auto out = dir_.file("analogy.txt");
  const auto run = run_client(grpc() + " analogy --a " + s5("walkingdog_1.txt") + " --b " + s5("walking_1.txt") +
                              " --c " + s5("walking_2.txt") + " --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(motion_rows(out).size(), 150u);
}

TEST_F(ClientTest, AnalogyRefusesAMissingInputBeforeCallingTheServer) {
  const auto run = run_client(grpc() + " analogy --a " + dir_.file("none.txt") + " --b " + s5("walking_1.txt") +
                              " --c " + s5("walking_2.txt") + " --out " + dir_.file("x.txt"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("none.txt: cannot open the file"), std::string::npos) << run.err;
}

// ---------------------------------------------------------------- denoise

TEST_F(ClientTest, DenoiseKeepsTheRootTranslationOfItsInput) {
  const auto out = dir_.file("denoised.txt");
  const auto run = run_client(rest() + " denoise --input " + s5("walking_1.txt") + " --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto rows = motion_rows(out);
  ASSERT_EQ(rows.size(), 150u);
  // Frame 0 at 25 Hz is frame 0 of the 50 Hz file.
  const auto input = motion_rows(s5("walking_1.txt"));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(rows[0][c], input[0][c], 1e-4);
}

TEST_F(ClientTest, DenoiseRefusesContradictoryOptions) {
  const auto run = run_client(grpc() + " denoise --zeros-are-missing --means-are-missing --input " +
                              s5("walking_1.txt") + " --out " + dir_.file("d.txt"));
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: ", 0), 0u) << run.err;
}

// ------------------------------------------------------------------- join

TEST_F(ClientTest, JoinWritesClipAThenTheTransitionThenClipB) {
  // Two short clips read whole: 4 s of walking and 4 s of sitting at 50 Hz,
  // 100 frames each at 25 Hz; a 1 s transition makes 175 frames. A
  // crossfade, to keep the test short: join_clips_service_tests covers the
  // generated transition (10 s and more of the server's CPU).
  const auto walking = motion_rows(s5("walking_1.txt")), sitting = motion_rows(s5("sitting_1.txt"));
  const auto write_rows = [&](const std::vector<std::vector<double>>& rows, const std::string& name) {
    std::ofstream out(dir_.file(name));
    out.precision(9);
    for (int r = 0; r < 200; ++r) {
      for (size_t c = 0; c < rows[r].size(); ++c) out << (c ? "," : "") << rows[r][c];
      out << "\n";
    }
    return dir_.file(name);
  };
  const auto out = dir_.file("joined.txt");
  const auto run = run_client(grpc() + " join --a " + write_rows(walking, "walk.txt") + " --b " +
                              write_rows(sitting, "sit.txt") + " --seconds 1 --method crossfade --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("the transition frames 75 to 99 (crossfade)"), std::string::npos) << run.err;
  const auto rows = motion_rows(out);
  ASSERT_EQ(rows.size(), 175u);
  const auto near = [](double got, double expected) { return std::fabs(got - expected) <= 1e-5 * std::max(1.0, std::fabs(expected)); };
  for (int f = 0; f < 175; ++f) {
    if (f >= 75 && f < 100) continue;  // the transition
    const auto& expected = f < 75 ? walking[2 * f] : sitting[2 * (f - 75)];
    for (size_t c = 0; c < expected.size(); ++c) {
      ASSERT_TRUE(near(rows[f][c], expected[c])) << "frame " << f << " column " << c << ": " << rows[f][c] << " against " << expected[c];
    }
  }
}

// ----------------------------------------------------------------- models

TEST_F(ClientTest, ModelsListAndDescribeShowTheStore) {
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " --json models list");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    std::vector<std::string> names;
    const auto reply = json::parse(run.out);
    for (const auto& m : reply["models"]) names.push_back(m["name"]);
    EXPECT_NE(std::find(names.begin(), names.end(), "h36m-dkgm-cpu"), names.end()) << run.out;
    EXPECT_NE(std::find(names.begin(), names.end(), "h36m-dkgm-h100"), names.end()) << run.out;

    const auto described = run_client(protocol + " --json models describe h36m-dkgm-cpu");
    ASSERT_EQ(described.exit_code, 0) << described.err;
    const auto model = json::parse(described.out);
    EXPECT_EQ(model["latent"], 64);
    EXPECT_EQ(model["frames"], 150);
    EXPECT_TRUE(model["provenance"].is_object());
    EXPECT_EQ(model["skeleton"]["name"], "h36m-32");

    // Without a name: the active model.
    const auto active = run_client(protocol + " --json models describe");
    ASSERT_EQ(active.exit_code, 0) << active.err;
    EXPECT_EQ(json::parse(active.out)["name"], "h36m-dkgm-h100");
    EXPECT_TRUE(json::parse(active.out)["active"].get<bool>());
  }
  const auto plain = run_client(grpc() + " models list");
  EXPECT_NE(plain.out.find("h36m-dkgm-cpu"), std::string::npos) << plain.out;
  const auto missing = run_client(grpc() + " models describe no-such-model");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_EQ(missing.err.rfind("error: NOT_FOUND: model: ", 0), 0u) << missing.err;
}

TEST_F(ClientTest, ActivateChangesTheAnsweringModelAndNeedsTheToken) {
  const auto before = json::parse(run_client(grpc() + " --json models describe").out);
  const std::string original = before["name"];
  const std::string other = original == "h36m-dkgm-cpu" ? "h36m-dkgm-h100" : "h36m-dkgm-cpu";

  auto run = run_client(grpc() + " --token wrong models activate " + other);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: authorization: ", 0), 0u) << run.err;
  run = run_client(rest() + " models activate " + other);  // no token at all
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: ", 0), 0u) << run.err;

  run = run_client(grpc() + " " + token() + " models activate " + other);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("active model: " + other), std::string::npos) << run.out;
  const auto sampled = run_client(grpc() + " --json sample --seed 1");
  ASSERT_EQ(sampled.exit_code, 0) << sampled.err;
  EXPECT_EQ(json::parse(sampled.out)["answered_by"]["model"], other);

  // Back, over REST.
  run = run_client(rest() + " " + token() + " models activate " + original);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(json::parse(run_client(rest() + " --json sample --seed 1").out)["answered_by"]["model"], original);
  run = run_client(grpc() + " " + token() + " models activate no-such-model");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: NOT_FOUND: ", 0), 0u) << run.err;
}

// ------------------------------------------------------------------ clips
// The data root is the operator's: its clips are read with the token.

TEST_F(ClientTest, ClipsNeedTheTokenOfAServerThatHasOne) {
  for (const auto& protocol : {grpc(), rest()}) {
    for (const std::string command : {" clips list", " --json clips read small/S5/walking_1.txt"}) {
      const auto run = run_client(protocol + command);
      EXPECT_EQ(run.exit_code, 1) << command;
      EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: ", 0), 0u) << run.err;
    }
  }
}

TEST_F(ClientTest, ClipsListTheDataRootsFilesOverBothProtocols) {
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " " + token() + " --json clips list");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto reply = json::parse(run.out);
    EXPECT_FALSE(reply["truncated"].get<bool>());
    std::vector<std::string> paths;
    for (const auto& clip : reply["clips"]) {
      paths.push_back(clip["path"]);
      EXPECT_EQ(clip["format"], "h36m-text");
      EXPECT_EQ(clip["size_bytes"].get<int64_t>(),
                static_cast<int64_t>(fs::file_size(test::h36m_dataset_dir() / clip["path"].get<std::string>().substr(6))))
          << clip.dump();
    }
    EXPECT_EQ(paths, (std::vector<std::string>{"small/S1/eating_1.txt", "small/S1/walking_1.txt",
                                               "small/S1/walking_2.txt", "small/S5/walking_1.txt"}));
  }
  const auto plain = run_client(grpc() + " " + token() + " clips list");
  EXPECT_NE(plain.out.find("h36m-text"), std::string::npos) << plain.out;
  EXPECT_NE(plain.out.find("small/S5/walking_1.txt"), std::string::npos) << plain.out;
}

TEST_F(ClientTest, ClipsReadWritesEverySecondRowFromStartAsTheServerAnswers) {
  const auto rows = motion_rows(s5("walking_1.txt"));
  for (const auto& protocol : {grpc(), rest()}) {
    const std::string out = dir_.file("window.txt");
    const auto run = run_client(protocol + " " + token() + " clips read small/S5/walking_1.txt --start 7 --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find("150 frames at 25 Hz of small/S5/walking_1.txt from frame 7 of " +
                           std::to_string(rows.size()) + " at 50 Hz (last start " + std::to_string(rows.size() - 300)),
              std::string::npos)
        << run.out;
    const auto window = motion_rows(out);
    ASSERT_EQ(window.size(), 150u);
    for (size_t k = 0; k < window.size(); ++k) {
      ASSERT_EQ(window[k].size(), 99u);
      for (size_t c = 0; c < 99; ++c) ASSERT_NEAR(window[k][c], rows[7 + 2 * k][c], 1e-6) << k << " " << c;
    }
  }
  // --json prints the server's reply, as REST answers it.
  const test::Reply direct = test::get(server_->rest_port(), "/v1/clips/window?path=small%2FS5%2Fwalking_1.txt&start=7",
                                            test::bearer(kToken));
  ASSERT_EQ(direct.status, 200) << direct.body;
  const auto run = run_client(grpc() + " " + token() + " --json clips read small/S5/walking_1.txt --start 7");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  auto printed = json::parse(run.out), answered = direct.document;
  // Floats compared as floats: the server writes each one's shortest form.
  EXPECT_EQ(printed["motion"]["values"].get<std::vector<float>>(), answered["motion"]["values"].get<std::vector<float>>());
  printed["motion"].erase("values");
  answered["motion"].erase("values");
  EXPECT_EQ(printed, answered);
}

// --whole writes every row of the file at its own rate, over both
// protocols; a start with it is refused naming start, as the server does.
TEST_F(ClientTest, ClipsReadWholeWritesEveryRowOfTheFile) {
  const auto rows = motion_rows(s5("walking_1.txt"));
  for (const auto& protocol : {grpc(), rest()}) {
    const std::string out = dir_.file("whole.txt");
    const auto run = run_client(protocol + " " + token() + " clips read small/S5/walking_1.txt --whole --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find(std::to_string(rows.size()) + " frames at 50 Hz, the whole of small/S5/walking_1.txt"),
              std::string::npos)
        << run.out;
    const auto whole = motion_rows(out);
    ASSERT_EQ(whole.size(), rows.size());
    for (size_t k = 0; k < whole.size(); ++k) {
      ASSERT_EQ(whole[k].size(), 99u);
      for (size_t c = 0; c < 99; ++c) ASSERT_NEAR(whole[k][c], rows[k][c], 1e-6) << k << " " << c;
    }
    const auto refused = run_client(protocol + " " + token() + " clips read small/S5/walking_1.txt --whole --start 2 --out " + out);
    EXPECT_NE(refused.exit_code, 0);
    EXPECT_NE(refused.err.find("start"), std::string::npos) << refused.err;
  }
}

// A take whose markers dropped out (nan in its joint columns) is read whole
// as it is: each missing value comes back as nan in the same row and
// column, over both protocols (REST carries it as "NaN"), and every other
// value as the file has it.
TEST_F(ClientTest, ClipsReadWholeKeepsATakesMissingValuesWhereTheFileHasThem) {
  auto rows = motion_rows(s5("walking_1.txt"));
  rows.resize(120);
  const auto lost = [](size_t row, size_t column) {
    return (row >= 30 && row < 45 && column >= 12 && column < 18) || (row >= 90 && row < 100 && column >= 3);
  };
  const fs::path file = scratch_->path() / "data" / "lost" / "walking_1_lost.txt";
  fs::create_directories(file.parent_path());
  {
    std::ofstream out(file);
    out.precision(9);
    for (size_t k = 0; k < rows.size(); ++k) {
      for (size_t c = 0; c < rows[k].size(); ++c) {
        if (c) out << ',';
        if (lost(k, c)) {
          out << "nan";
        } else {
          out << rows[k][c];
        }
      }
      out << '\n';
    }
  }
  for (const auto& protocol : {grpc(), rest()}) {
    const std::string out = dir_.file("lost.txt");
    const auto run = run_client(protocol + " " + token() + " clips read lost/walking_1_lost.txt --whole --out " + out);
    ASSERT_EQ(run.exit_code, 0) << protocol << ": " << run.err;
    const auto whole = motion_rows(out);
    ASSERT_EQ(whole.size(), rows.size()) << protocol;
    size_t missing = 0;
    for (size_t k = 0; k < whole.size(); ++k) {
      ASSERT_EQ(whole[k].size(), 99u);
      for (size_t c = 0; c < 99; ++c) {
        if (lost(k, c)) {
          ASSERT_TRUE(std::isnan(whole[k][c])) << protocol << " row " << k << " column " << c << ": " << whole[k][c];
          ++missing;
        } else {
          ASSERT_NEAR(whole[k][c], rows[k][c], 1e-6) << protocol << " row " << k << " column " << c;
        }
      }
    }
    EXPECT_EQ(missing, 15u * 6 + 10u * 96) << protocol;
  }
  fs::remove_all(file.parent_path());
}

// One unit for every start: encode --start counts the file's rows as
// clips read --start and REST's start= do, so the same start of the same
// file is the same window and gives the same code (an odd row included).
TEST_F(ClientTest, EncodeStartCountsTheFilesRowsAsClipsReadAndRestDo) {
  const std::string window = dir_.file("window_7.txt");
  ASSERT_EQ(run_client(grpc() + " " + token() + " clips read small/S5/walking_1.txt --start 7 --out " + window)
                .exit_code,
            0);
  const auto from_window = run_client(grpc() + " encode --rate 25 --input " + window);
  const auto from_start = run_client(grpc() + " encode --start 7 --input " + s5("walking_1.txt"));
  ASSERT_EQ(from_window.exit_code, 0) << from_window.err;
  ASSERT_EQ(from_start.exit_code, 0) << from_start.err;
  const auto a = code_of(from_window.out), b = code_of(from_start.out);
  ASSERT_EQ(a.size(), 64u);
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a[i], b[i], 1e-6) << i;
  const auto unshifted = code_of(run_client(grpc() + " encode --input " + s5("walking_1.txt")).out);
  EXPECT_NE(unshifted, b) << "--start must move the window";
}

TEST_F(ClientTest, ClipsReadReportsTheServersRefusalsNamingTheField) {
  const auto rows = motion_rows(s5("walking_1.txt"));
  for (const auto& protocol : {grpc(), rest()}) {
    auto run = run_client(protocol + " " + token() + " --json clips read small/S5/walking_1.txt --start " +
                          std::to_string(rows.size() - 299));
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: start: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("expected 0 to " + std::to_string(rows.size() - 300)), std::string::npos) << run.err;
    run = run_client(protocol + " " + token() + " --json clips read ../outside.txt");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: path: ", 0), 0u) << run.err;
    run = run_client(protocol + " " + token() + " --json clips read small/S5/no_such_file.txt");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: NOT_FOUND: path: ", 0), 0u) << run.err;
  }
  const auto no_output = run_client(grpc() + " clips read small/S5/walking_1.txt");
  EXPECT_EQ(no_output.exit_code, 2);
  EXPECT_NE(no_output.err.find("--out is required"), std::string::npos) << no_output.err;
}

// ------------------------------------------------------------------- jobs

const char* const kTinyJob = "jobs submit --dataset small --variant D --hidden 16 --batch 4 --iterations 30 --seed 3";

TEST_F(ClientTest, ASubmittedJobIsWatchedToItsEndListedAndGot) {
  const auto submitted = run_client(grpc() + " " + token() + " " + kTinyJob + " --model-name client-tiny");
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  const std::string id = submitted.out.substr(0, submitted.out.find('\n'));
  ASSERT_FALSE(id.empty());

  // Not on a terminal: one plain line per change, the last the final state.
  const auto watched = run_client(grpc() + " jobs watch " + id);
  ASSERT_EQ(watched.exit_code, 0) << watched.out << watched.err;
  EXPECT_NE(watched.out.find("job " + id + " running"), std::string::npos) << watched.out;
  EXPECT_NE(watched.out.find("job " + id + " succeeded 30/30 (100%)"), std::string::npos) << watched.out;
  EXPECT_NE(watched.out.find("-> model client-tiny"), std::string::npos) << watched.out;
  EXPECT_NE(watched.out.find("it/s"), std::string::npos) << watched.out;

  // Watching a finished job over REST gives its final record at once.
  const auto rest_watch = run_client(rest() + " --json jobs watch " + id);
  ASSERT_EQ(rest_watch.exit_code, 0) << rest_watch.err;
  const auto last_line = rest_watch.out.substr(rest_watch.out.rfind('\n', rest_watch.out.size() - 2) + 1);
  EXPECT_EQ(json::parse(last_line)["state"], "succeeded");

  for (const auto& protocol : {grpc(), rest()}) {
    const auto listed = run_client(protocol + " --json jobs list");
    ASSERT_EQ(listed.exit_code, 0) << listed.err;
    bool found = false;
    const auto reply = json::parse(listed.out);
    for (const auto& job : reply["jobs"]) found = found || job["id"] == id;
    EXPECT_TRUE(found) << listed.out;
    const auto got = run_client(protocol + " --json jobs get " + id);
    ASSERT_EQ(got.exit_code, 0) << got.err;
    const auto job = json::parse(got.out);
    EXPECT_EQ(job["state"], "succeeded");
    EXPECT_EQ(job["progress"]["iteration"], 30);
    EXPECT_EQ(job["published_model"], "client-tiny");
    EXPECT_EQ(job["spec"]["variant"], "D");
    // The whole configuration it trained: the spec's values, the rest D's.
    const auto& config = job["resolved_config"];
    EXPECT_EQ(config["model"]["hidden"], 16) << got.out;
    EXPECT_EQ(config["batch"], 4) << got.out;
    EXPECT_EQ(config["iterations"], 30) << got.out;
    EXPECT_EQ(config["seed"], 3) << got.out;
    EXPECT_EQ(config["variant"], "D") << got.out;
    EXPECT_EQ(config["model"]["latent"], 64) << got.out;
    EXPECT_EQ(config["weights"]["position"], 0.0) << got.out;
    const auto plain = run_client(protocol + " jobs get " + id);
    ASSERT_EQ(plain.exit_code, 0) << plain.err;
    EXPECT_NE(plain.out.find("\nconfiguration: {"), std::string::npos) << plain.out;
    EXPECT_NE(plain.out.find("\"hidden\":16"), std::string::npos) << plain.out;
  }
  // A finished job cannot be cancelled.
  const auto cancel = run_client(grpc() + " " + token() + " jobs cancel " + id);
  EXPECT_EQ(cancel.exit_code, 1);
  EXPECT_EQ(cancel.err.rfind("error: FAILED_PRECONDITION: ", 0), 0u) << cancel.err;
}

TEST_F(ClientTest, ARunningJobIsCancelledAndItsWatchEndsNonZero) {
  const auto submitted = run_client(rest() + " " + token() +
                                    " jobs submit --dataset small --variant D --hidden 16 --batch 4 "
                                    "--iterations 1000000");
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  const std::string id = submitted.out.substr(0, submitted.out.find('\n'));
  const auto cancelled = run_client(rest() + " " + token() + " --json jobs cancel " + id);
  ASSERT_EQ(cancelled.exit_code, 0) << cancelled.err;
  const auto watched = run_client(grpc() + " jobs watch " + id);
  EXPECT_EQ(watched.exit_code, 1);
  EXPECT_NE(watched.out.find("cancelled"), std::string::npos) << watched.out;
  EXPECT_NE(watched.err.find("error: job " + id + " cancelled"), std::string::npos) << watched.err;
}

TEST_F(ClientTest, JobCommandsReportTheServersRefusals) {
  auto run = run_client(grpc() + " " + kTinyJob);  // no token
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: authorization: ", 0), 0u) << run.err;
  run = run_client(rest() + " --token wrong " + kTinyJob);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: authorization: ", 0), 0u) << run.err;
  run = run_client(grpc() + " " + token() + " jobs submit --dataset ../outside --variant D");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: dataset: ", 0), 0u) << run.err;
  run = run_client(grpc() + " " + token() + " jobs submit --dataset small --config " + dir_.file("none.json"));
  EXPECT_EQ(run.exit_code, 2);
  for (const auto& protocol : {grpc(), rest()}) {
    for (const std::string command : {"jobs get", "jobs watch", "jobs cancel"}) {
      run = run_client(protocol + " " + token() + " " + command + " no-such-job");
      EXPECT_EQ(run.exit_code, 1) << command;
      EXPECT_EQ(run.err.rfind("error: NOT_FOUND: id: ", 0), 0u) << command << ": " << run.err;
    }
  }
}

// ----------------------------------------------------------------- delete

TEST_F(ClientTest, DeleteCommandsRemoveAModelAFinishedJobAndAnUploadAndNeedTheToken) {
  const fs::path store = server_->model_store();
  for (const char* name : {"client-doomed-1", "client-doomed-2"}) {
    fs::copy(fs::path(MM_SOURCE_DIR) / "models" / "h36m-dkgm-cpu", store / name, fs::copy_options::recursive);
  }
  // Without the token, or with a wrong one: refused, nothing removed.
  for (const std::string& command : {"models delete client-doomed-1", "jobs delete no-such-job",
                                     "clips delete small/S1/walking_1.txt"}) {
    for (const auto& protocol : {grpc(), rest() + " --token wrong"}) {
      const auto run = run_client(protocol + " " + command);
      EXPECT_EQ(run.exit_code, 1) << command;
      EXPECT_EQ(run.err.rfind("error: UNAUTHENTICATED: authorization: ", 0), 0u) << command << ": " << run.err;
    }
  }
  EXPECT_TRUE(fs::exists(store / "client-doomed-1" / "manifest.json"));

  // A model, over either protocol: gone from the listing and the store.
  auto run = run_client(grpc() + " " + token() + " models delete client-doomed-1");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("deleted model: client-doomed-1"), std::string::npos) << run.out;
  run = run_client(rest() + " " + token() + " --json models delete client-doomed-2");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(json::parse(run.out)["name"], "client-doomed-2");
  const std::string listed = run_client(grpc() + " models list").out;
  for (const char* name : {"client-doomed-1", "client-doomed-2"}) {
    EXPECT_FALSE(fs::exists(store / name)) << name;
    EXPECT_EQ(listed.find(name), std::string::npos) << listed;
  }
  const std::string active = json::parse(run_client(grpc() + " --json models describe").out)["name"];
  run = run_client(rest() + " " + token() + " models delete " + active);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_EQ(run.err.rfind("error: FAILED_PRECONDITION: model: ", 0), 0u) << run.err;

  // A finished job: its record and folder go.
  const auto submitted = run_client(grpc() + " " + token() + " " + kTinyJob);
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  const std::string id = submitted.out.substr(0, submitted.out.find('\n'));
  ASSERT_EQ(run_client(grpc() + " jobs watch " + id).exit_code, 0);
  run = run_client(rest() + " " + token() + " jobs delete " + id);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("deleted job: " + id), std::string::npos) << run.out;
  EXPECT_FALSE(fs::exists(scratch_->path() / "state" / "jobs" / id));
  for (const auto& protocol : {grpc(), rest()}) {
    run = run_client(protocol + " " + token() + " jobs delete " + id);
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: NOT_FOUND: id: ", 0), 0u) << run.err;
  }

  // Uploads go; the operator's files stay.
  const fs::path data = scratch_->path() / "data";
  for (const auto& protocol : {grpc(), rest()}) {
    run = run_client(protocol + " " + token() + " clips upload " + s5("walking_1.txt") + " --to client-up");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    ASSERT_TRUE(fs::exists(data / "client-up" / "walking_1.txt"));
    run = run_client(protocol + " " + token() + " --json clips delete client-up/walking_1.txt");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(json::parse(run.out)["clips"][0]["path"], "client-up/walking_1.txt");
    EXPECT_FALSE(fs::exists(data / "client-up" / "walking_1.txt"));
    run = run_client(protocol + " " + token() + " clips delete small/S1/walking_1.txt");
    EXPECT_EQ(run.exit_code, 1);
    EXPECT_EQ(run.err.rfind("error: FAILED_PRECONDITION: path: ", 0), 0u) << run.err;
    EXPECT_TRUE(fs::exists(data / "small" / "S1" / "walking_1.txt"));
  }
}

// On a terminal (script(1) gives the client one) an upload shows the bytes
// sent of all its files' on stderr from its start, the line cleared before
// the files are listed; off a terminal nothing is drawn.
TEST_F(ClientTest, OnATerminalAnUploadShowsTheBytesSent) {
  const fs::path folder = dir_.path() / "takes";
  fs::create_directories(folder / "b");
  fs::copy_file(s5("walking_1.txt"), folder / "a.txt");
  fs::copy_file(s5("walking_2.txt"), folder / "b" / "c.txt");
  const auto total = fs::file_size(folder / "a.txt") + fs::file_size(folder / "b" / "c.txt");
  const std::string command = std::string(MM_CLIENT_PATH) + " " + grpc() + " " + token() + " clips upload " +
                              folder.string() + " --to terminal-up";
  const std::string typescript = dir_.file("typescript");
  const auto run = test::run_command("script", "-qec '" + command + "' " + typescript);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string shown = test::read_text(typescript);
  std::string grouped = std::to_string(total);
  for (int at = static_cast<int>(grouped.size()) - 3; at > 0; at -= 3) grouped.insert(static_cast<size_t>(at), ",");
  // Drawn at once and twice a second after: a fast upload may show 0%.
  EXPECT_NE(shown.find("clips upload to terminal-up: "), std::string::npos) << shown;
  EXPECT_NE(shown.find(" of " + grouped + " bytes ("), std::string::npos) << shown;
  EXPECT_NE(shown.find("terminal-up/b/c.txt"), std::string::npos) << shown;
  const auto piped = run_client(grpc() + " " + token() + " clips upload " + s5("walking_1.txt") + " --to piped-up");
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_EQ(piped.err.find("bytes ("), std::string::npos) << piped.err;
}

// A job watch outlives the server: killed and started again at the same
// address, it resumes the job from its checkpoint and the watch follows it
// to the end.
TEST(ClientJobWatch, SurvivesAServerRestart) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  test::ServerProcess server(job_server_args(scratch.path()));
  const std::string connection = "--server " + server.grpc_target() + " --token " + kToken;
  const auto submitted =
      run_client(connection + " jobs submit --dataset small --variant D --hidden 16 --batch 4 --iterations 300");
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  const std::string id = submitted.out.substr(0, submitted.out.find('\n'));

  // The watch in the background, its streams to files.
  const std::string out = scratch.file("watch.out"), err = scratch.file("watch.err");
  const pid_t watcher = fork();
  ASSERT_GE(watcher, 0);
  if (watcher == 0) {
    const std::string command = std::string(MM_CLIENT_PATH) + " " + connection + " jobs watch " + id + " >" + out +
                                " 2>" + err;
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // Killed once the job has checkpointed (every 5 iterations).
  json job;
  for (int i = 0; i < 1500; ++i) {
    const auto got = run_client("--server " + server.grpc_target() + " --json jobs get " + id);
    if (got.exit_code == 0) job = json::parse(got.out);
    if (job.value("state", "") != "queued" && job["progress"].value("iteration", 0) >= 12) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_EQ(job["state"], "running") << job.dump();
  server.kill();
  std::this_thread::sleep_for(std::chrono::seconds(1));  // the watch sees the server gone
  server.restart_on_same_ports();

  int status = -1;
  for (int i = 0; i < 3000 && waitpid(watcher, &status, WNOHANG) == 0; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  if (status == -1) {
    kill(watcher, SIGKILL);
    waitpid(watcher, &status, 0);
  }
  const std::string watch_out = read_text(out), watch_err = read_text(err);
  ASSERT_TRUE(WIFEXITED(status)) << watch_out << watch_err;
  EXPECT_EQ(WEXITSTATUS(status), 0) << watch_out << watch_err;
  EXPECT_NE(watch_err.find("connection lost (UNAVAILABLE"), std::string::npos) << watch_err;
  EXPECT_NE(watch_out.find("job " + id + " succeeded 300/300"), std::string::npos) << watch_out;
  EXPECT_NE(watch_out.find("(resumed 1x)"), std::string::npos) << watch_out;
}

}  // namespace
}  // namespace mm
