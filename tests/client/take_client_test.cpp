// motion-manifold-client's take commands end to end: the real client binary
// against the real server on loopback, a whole H3.6M file and a 120 Hz BVH
// streamed over gRPC and sent over REST, their replies at the input's rate
// and length, code tracks written and decoded, and refusals with their exit
// statuses (1: the server refused, 2: bad local input).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/client/client_files.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

using nlohmann::json;
using test::motion_rows;
using test::read_text;
using test::run_client;
using test::s5;

// A BVH file's "Frames:" and "Frame Time:".
struct BvhTiming {
  long frames = -1;
  double frame_time = 0;
};

BvhTiming bvh_timing(const std::string& path) {
  BvhTiming timing;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("Frames:", 0) == 0) timing.frames = std::stol(line.substr(7));
    if (line.rfind("Frame Time:", 0) == 0) {
      timing.frame_time = std::stod(line.substr(11));
      break;
    }
  }
  return timing;
}

// Non-blank lines of a file.
size_t line_count(const std::string& path) {
  size_t lines = 0;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) lines += !line.empty();
  return lines;
}

// Windows of 6 s every 3 s over `seconds`, the last aligned to the end.
size_t windows_over(double seconds) { return static_cast<size_t>(std::ceil((seconds - 6.0) / 3.0 - 1e-9)) + 1; }

// One server for the suite, without a token: take operations need none.
class TakeClientTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (test::has_h36m()) server_ = new test::ServerProcess(std::vector<std::string>{});
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  void SetUp() override {
    MM_REQUIRE_H36M();
    ASSERT_NE(server_, nullptr);
  }

  static std::string grpc() { return "--server " + server_->grpc_target(); }
  static std::string rest() { return "--rest --rest-url " + server_->rest_url(); }

  static test::ServerProcess* server_;
  test::ScratchDir dir_;
};

test::ServerProcess* TakeClientTest::server_ = nullptr;

TEST_F(TakeClientTest, ReconstructOfAWholeS5FileKeepsItsFramesRateAndRootOverBothProtocols) {
  const auto input = motion_rows(s5("walking_1.txt"));
  ASSERT_GT(input.size(), 1000u);
  for (const auto& protocol : {grpc(), rest()}) {
    const auto out = dir_.file("walk.txt"), errors = dir_.file("walk-error.csv");
    const auto run = run_client(protocol + " take reconstruct --in " + s5("walking_1.txt") + " --out " + out +
                                " --error-csv " + errors);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.out.find(std::to_string(input.size()) + " frames at 50 Hz"), std::string::npos) << run.out;
    const auto output = motion_rows(out);
    ASSERT_EQ(output.size(), input.size()) << protocol;
    for (size_t f = 0; f < output.size(); ++f) {
      ASSERT_EQ(output[f].size(), 99u);
      // The root's translation is the input's, copied.
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(output[f][c], input[f][c], 1e-4) << f;
    }
    // A header and one line a frame, each a finite error in mm.
    EXPECT_EQ(line_count(errors), input.size() + 1);
    std::ifstream csv(errors);
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line, "frame,seconds,error_mm");
    double sum = 0;
    size_t n = 0;
    while (std::getline(csv, line)) {
      const double error = std::stod(line.substr(line.rfind(',') + 1));
      ASSERT_TRUE(std::isfinite(error) && error >= 0) << line;
      sum += error;
      ++n;
    }
    EXPECT_EQ(n, input.size());
    EXPECT_GT(sum / n, 0.0);
  }
  // The same take as BVH, at its rate: written here from gRPC's frames, and
  // over REST the server's own BVH (Accept: application/x-bvh), the same bytes.
  const auto bvh = dir_.file("walk.bvh"), rest_bvh = dir_.file("walk-rest.bvh");
  auto run = run_client(grpc() + " take reconstruct --in " + s5("walking_1.txt") + " --out " + bvh);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto timing = bvh_timing(bvh);
  EXPECT_EQ(timing.frames, static_cast<long>(input.size()));
  EXPECT_NEAR(timing.frame_time, 0.02, 1e-6);
  run = run_client(rest() + " take reconstruct --in " + s5("walking_1.txt") + " --out " + rest_bvh);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find(std::to_string(input.size()) + " frames at 50 Hz"), std::string::npos) << run.out;
  EXPECT_TRUE(read_text(bvh) == read_text(rest_bvh)) << "gRPC's and REST's BVH differ";
}

TEST_F(TakeClientTest, EncodeWritesACodeTrackThatTrackDecodeTurnsIntoA120HzBvhWhichReconstructsAtItsRate) {
  const size_t input_frames = motion_rows(s5("walking_1.txt")).size();
  const double seconds = (input_frames - 1) / 50.0;
  json tracks[2];
  int i = 0;
  for (const auto& protocol : {grpc(), rest()}) {
    const auto track = dir_.file("track" + std::to_string(i) + ".json");
    const auto run = run_client(protocol + " take encode --in " + s5("walking_1.txt") + " --out " + track);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    tracks[i] = json::parse(read_text(track));
    EXPECT_EQ(tracks[i]["frames"], input_frames);
    EXPECT_EQ(tracks[i]["frame_rate"], 50.0);
    ASSERT_EQ(tracks[i]["windows"].size(), windows_over(seconds)) << tracks[i].dump().substr(0, 400);
    EXPECT_EQ(tracks[i]["windows"][0]["code"].size(), 64u);
    EXPECT_EQ(tracks[i]["windows"][1]["start_seconds"], 3.0);
    ++i;
  }
  // Both protocols give the same track.
  for (size_t w = 0; w < tracks[0]["windows"].size(); ++w) {
    for (size_t k = 0; k < 64; ++k) {
      ASSERT_NEAR(tracks[0]["windows"][w]["code"][k].get<double>(), tracks[1]["windows"][w]["code"][k].get<double>(),
                  1e-4);
    }
  }

  // The track decoded at 120 Hz: a BVH of H3.6M's skeleton covering the take.
  const auto decoded = dir_.file("decoded120.bvh");
  auto run = run_client(grpc() + " track decode --in " + dir_.file("track0.json") + " --rate 120 --out " + decoded);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto timing = bvh_timing(decoded);
  EXPECT_NEAR(timing.frame_time, 1.0 / 120, 1e-6);
  // The track ends with its last window, whose start is on the model's 25 Hz grid: within 0.04 s of the take's end.
  EXPECT_LE(timing.frames, static_cast<long>(seconds * 120) + 1);
  EXPECT_GE(timing.frames, static_cast<long>((seconds - 0.04) * 120));
  // REST decodes the same track (as REST's own encode wrote it) to as many frames.
  run = run_client(rest() + " track decode --in " + dir_.file("track1.json") + " --rate 120 --out " +
                   dir_.file("decoded120.txt"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(static_cast<long>(line_count(dir_.file("decoded120.txt"))), timing.frames);

  // That 120 Hz BVH is a take of its own: reconstructed at 120 Hz, frame for frame.
  for (const auto& protocol : {grpc(), rest()}) {
    const auto out = dir_.file("again.bvh"), errors = dir_.file("again.csv");
    run = run_client(protocol + " take reconstruct --in " + decoded + " --out " + out + " --error-csv " + errors);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto again = bvh_timing(out);
    EXPECT_EQ(again.frames, timing.frames) << protocol;
    EXPECT_NEAR(again.frame_time, 1.0 / 120, 1e-6) << protocol;
    EXPECT_EQ(static_cast<long>(line_count(errors)), timing.frames + 1);
    EXPECT_NE(run.out.find("at 120 Hz"), std::string::npos) << run.out;
  }
  // With --at-model-rate the reply comes at 25 Hz.
  run = run_client(grpc() + " take reconstruct --at-model-rate --in " + decoded + " --out " + dir_.file("at25.txt"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(static_cast<long>(line_count(dir_.file("at25.txt"))), (timing.frames - 1) * 25 / 120 + 1);
}

TEST_F(TakeClientTest, DenoiseFillsTheMissingValuesOfATextTake) {
  // The first 20 s of S5 walking with one joint's values missing (nan).
  auto rows = motion_rows(s5("walking_1.txt"));
  rows.resize(1000);
  std::string text;
  for (auto& row : rows) {
    for (size_t c = 0; c < row.size(); ++c) {
      char value[32];
      std::snprintf(value, sizeof value, "%.7f", row[c]);
      text += (c ? "," : "") + std::string(c >= 21 && c < 24 ? "nan" : value);
    }
    text += "\n";
  }
  const auto noisy = dir_.write("noisy.txt", text);
  for (const auto& protocol : {grpc(), rest()}) {
    const auto out = dir_.file("clean.txt");
    const auto run = run_client(protocol + " take denoise --keep-observed --in " + noisy + " --out " + out);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto clean = motion_rows(out);
    ASSERT_EQ(clean.size(), rows.size());
    for (size_t f = 0; f < clean.size(); ++f) {
      for (int c = 21; c < 24; ++c) ASSERT_TRUE(std::isfinite(clean[f][c])) << f;
      ASSERT_NEAR(clean[f][30], rows[f][30], 1e-4) << "observed values are kept";
    }
  }
}

// take denoise --gap-fill reaches the server over both protocols: 20 s of
// S5 walking with every joint missing for 2 s (frames 500 to 599), filled
// by slerp, comes back the same over gRPC and REST and unlike the default
// fill (borrowed: the walk's own steps, or a code fitted to the gap's
// window where none is like enough, the window fitted either way), whose
// line counts the window and the gap it fitted (from the gRPC summary and
// REST's X-Take-Gap* headers), as the fitted fill's does; slerp's counts
// none. A method the server does not know is
// refused naming --gap-fill.
TEST_F(TakeClientTest, DenoiseGapFillIsSentOverBothProtocolsAndTheFittedGapsAreCounted) {
  auto rows = motion_rows(s5("walking_1.txt"));
  rows.resize(1000);
  std::string text;
  for (size_t f = 0; f < rows.size(); ++f) {
    for (size_t c = 0; c < rows[f].size(); ++c) {
      char value[32];
      std::snprintf(value, sizeof value, "%.7f", rows[f][c]);
      text += (c ? "," : "") + std::string(f >= 500 && f < 600 && c >= 3 ? "nan" : value);
    }
    text += "\n";
  }
  const auto gapped = dir_.write("gapped.txt", text);
  std::map<std::string, std::vector<std::vector<double>>> filled;
  for (const auto& [name, command] :
       {std::pair<std::string, std::string>{"grpc slerp", grpc() + " take denoise --gap-fill slerp"},
        {"rest slerp", rest() + " take denoise --gap-fill slerp"},
        {"grpc default", grpc() + " take denoise"},
        {"rest fitted", rest() + " take denoise --gap-fill fitted"}}) {
    const auto out = dir_.file(std::to_string(filled.size()) + ".txt");
    const auto run = run_client(command + " --keep-observed --in " + gapped + " --out " + out);
    ASSERT_EQ(run.exit_code, 0) << name << ": " << run.err;
    const bool slerp = name.find("slerp") != std::string::npos;
    EXPECT_NE(run.out.find(slerp ? "gaps: 0 fitted in 0 windows, 0 over" : "gaps: 1 fitted in 1 windows, 0 over"),
              std::string::npos)
        << name << ": " << run.out;
    filled[name] = motion_rows(out);
    ASSERT_EQ(filled[name].size(), rows.size()) << name;
  }
  double rest_from_grpc = 0, slerp_from_fitted = 0, rest_fitted_from_grpc = 0;
  for (size_t f = 500; f < 600; ++f) {
    for (size_t c = 3; c < 99; ++c) {
      rest_from_grpc = std::max(rest_from_grpc, std::fabs(filled["rest slerp"][f][c] - filled["grpc slerp"][f][c]));
      slerp_from_fitted =
          std::max(slerp_from_fitted, std::fabs(filled["grpc slerp"][f][c] - filled["grpc default"][f][c]));
      rest_fitted_from_grpc =
          std::max(rest_fitted_from_grpc, std::fabs(filled["rest fitted"][f][c] - filled["grpc default"][f][c]));
    }
  }
  EXPECT_LE(rest_from_grpc, 1e-4) << "REST's slerp fill is gRPC's";
  EXPECT_GT(slerp_from_fitted, 0.05) << "slerp fills the gap otherwise than the fitted code";
  std::printf("[ gap fill ] largest difference in the gap: slerp from fitted %.3f rad, REST from gRPC: slerp %.2g, "
              "fitted %.2g\n",
              slerp_from_fitted, rest_from_grpc, rest_fitted_from_grpc);

  const auto run = run_client(grpc() + " take denoise --keep-observed --gap-fill spline --in " + gapped + " --out " +
                              dir_.file("refused.txt"));
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: --gap-fill: ", 0), 0u) << run.err;
}

TEST_F(TakeClientTest, RefusalsExitOneWithTheServersMessageAndBadLocalInputExitsTwo) {
  // Shorter than one window: the server names the minimum.
  std::string text;
  std::ifstream in(s5("walking_1.txt"));
  std::string line;
  for (int f = 0; f < 200 && std::getline(in, line); ++f) text += line + "\n";
  const auto short_take = dir_.write("short.txt", text);
  for (const auto& protocol : {grpc(), rest()}) {
    auto run = run_client(protocol + " take reconstruct --in " + short_take + " --out " + dir_.file("out.txt"));
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("6"), std::string::npos) << run.err;
    EXPECT_FALSE(std::filesystem::exists(dir_.file("out.txt")));

    run = run_client(protocol + " take encode --blend nope --in " + s5("walking_1.txt") + " --out " +
                     dir_.file("t.json"));
    EXPECT_EQ(run.exit_code, 2) << "encode has no --blend: " << run.err;
    run = run_client(protocol + " take reconstruct --blend nope --in " + s5("walking_1.txt") + " --out " +
                     dir_.file("out.txt"));
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: --blend: expected crossfade or cut", 0), 0u) << run.err;
  }
  // Bad local input, before any call.
  auto run = run_client(grpc() + " take reconstruct --rate 5 --in " + s5("walking_1.txt") + " --out " +
                        dir_.file("o.txt"));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  run = run_client(grpc() + " take reconstruct --in " + s5("walking_1.txt") + " --out " + dir_.file("o.csv"));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("o.csv"), std::string::npos) << run.err;
  run = run_client(grpc() + " take reconstruct --in " + dir_.write("bad.bvh", "HIERARCHY\n") + " --out " +
                   dir_.file("o.txt"));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("bad.bvh"), std::string::npos) << run.err;
  run = run_client(grpc() + " track decode --in " + dir_.write("t.json", "{\"windows\": [{\"code\": [1]}]}") +
                   " --out " + dir_.file("o.txt"));
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("windows[0].start_seconds"), std::string::npos) << run.err;
}

// The take commands take --input, as the tool and encode do, and --in as
// its alias; a BVH of a rate its Frame Time only nears (0.00833333 s) is
// shown at the rate it says, 120 Hz, not 120.000048.
TEST_F(TakeClientTest, TakeCommandsTakeInputOrInAndShowA120HzBvhAt120Hz) {
  const auto track = dir_.file("track.json");
  auto run = run_client(grpc() + " take encode --input " + s5("walking_1.txt") + " --out " + track);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto bvh = dir_.file("walk_120.bvh");
  run = run_client(grpc() + " track decode --input " + track + " --rate 120 --frames 960 --out " + bvh);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("960 frames at 120 Hz"), std::string::npos) << run.out;
  for (const auto& protocol : {grpc(), rest()}) {
    for (const char* option : {" --input ", " --in "}) {
      run = run_client(protocol + " --json take encode" + option + bvh + " --out " + dir_.file("t.json"));
      ASSERT_EQ(run.exit_code, 0) << option << run.err;
      EXPECT_EQ(json::parse(run.out)["frame_rate"], 120.0) << run.out;
      EXPECT_EQ(json::parse(read_text(dir_.file("t.json")))["frame_rate"], 120.0);
    }
    run = run_client(protocol + " --json take reconstruct --input " + bvh + " --out " + dir_.file("r.txt"));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(json::parse(run.out)["frame_rate"], 120.0) << run.out;
    EXPECT_EQ(json::parse(run.out)["frames"], 960) << run.out;
  }
}

// A refused option is named as the user typed it (the client) and its
// field once (REST: not "hop_seconds: hop_seconds: ...").
TEST_F(TakeClientTest, ARefusedHopNamesTheOptionInTheClientAndItsFieldOnceOverRest) {
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " take encode --hop 10 --input " + s5("walking_1.txt") + " --out " +
                                dir_.file("t.json"));
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_EQ(run.err.rfind("error: INVALID_ARGUMENT: --hop: expected 0.04 to 6 s", 0), 0u) << run.err;
    EXPECT_EQ(run.err.find("hop_seconds"), std::string::npos) << run.err;
  }
  const auto reply = test::post(server_->rest_port(), "/v1/takes:encode?frame_rate=50&hop_seconds=10",
                                read_text(s5("walking_1.txt")), {}, "text/plain");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_EQ(reply.field(), "hop_seconds") << reply.body;
  EXPECT_EQ(reply.error()["message"].get<std::string>().rfind("expected 0.04 to 6 s", 0), 0u) << reply.body;
}

// On a server without a token (scripts/serve.sh's default) the README's
// `-H "Authorization: Bearer $TOKEN"` with $TOKEN empty is no header: a
// call from loopback that changes state is let in; the client sends none
// for an empty --token.
TEST_F(TakeClientTest, AnEmptyBearerTokenIsNoTokenOnAServerWithoutOne) {
  const auto models = test::get(server_->rest_port(), "/v1/models");
  ASSERT_EQ(models.status, 200) << models.body;
  std::string active;
  for (const auto& model : models.document.at("models")) {
    if (model.value("active", false)) active = model.at("name").get<std::string>();
  }
  ASSERT_FALSE(active.empty()) << models.body;
  for (const char* header : {"Bearer ", "Bearer", "bearer  \t "}) {
    const auto reply = test::post(server_->rest_port(), "/v1/models/" + active + ":activate", std::string("{}"),
                                  {{"Authorization", header}});
    EXPECT_EQ(reply.status, 200) << "\"" << header << "\": " << reply.body;
  }
  // Another malformed header is still refused, naming why.
  const auto basic = test::post(server_->rest_port(), "/v1/models/" + active + ":activate", std::string("{}"),
                                {{"Authorization", "Basic dXNlcjpwYXNz"}});
  EXPECT_EQ(basic.status, 401) << basic.body;
  for (const auto& protocol : {grpc(), rest()}) {
    const auto run = run_client(protocol + " --token \"\" models activate " + active);
    EXPECT_EQ(run.exit_code, 0) << run.err;
  }
}

// BVH posted without its Content-Type (curl -d @walk.bvh) is read as JSON;
// the refusal says which type to send.
TEST_F(TakeClientTest, ABvhBodyWithoutItsContentTypeIsToldWhichToSend) {
  const auto bvh = dir_.file("walk.bvh");
  std::string code = "{\"code\": [0";
  for (int i = 1; i < 64; ++i) code += ", 0";
  code += "]}";
  const auto run = run_client(grpc() + " decode --code " + dir_.write("code.json", code) + " --out " + bvh);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto reply = test::post(server_->rest_port(), "/v1/encode", read_text(bvh), {},
                                "application/x-www-form-urlencoded");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.error()["message"].get<std::string>().find("Content-Type: application/x-bvh"), std::string::npos)
      << reply.body;
}

}  // namespace
}  // namespace mm
