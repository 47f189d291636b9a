// Work bounded before it is done, on the real server over REST: what a
// request will cost is read from its first bytes (a BVH's frame count and
// frame time, a body's declared length) and checked against a named limit
// before the work is paid for. The server's own CPU time and peak memory
// (/proc/PID/stat and /proc/PID/status) show that a refused request cost
// next to nothing; its latency is printed, not asserted. Synthetic motions
// only: no H3.6M data is needed.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <httplib.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "format/h36m_bvh.h"
#include "format/motion_frames.h"
#include "tests/common/process_cost.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// A BVH of the H3.6M skeleton with `frames` frames of small rotations at
// 25 Hz, as the library exports it.
std::string h36m_bvh(int frames) {
  MotionFrames motion;
  motion.values.assign(static_cast<size_t>(frames) * kH36mColumns, 0.0f);
  for (int f = 0; f < frames; ++f)
    for (int c = 3; c < kH36mColumns; ++c) motion.frame(f)[c] = 0.01f * static_cast<float>((f + c) % 7);
  return h36m_motion_to_bvh_text(motion, 25.0);
}

// 12 frames that each last an hour: 12.7 kB that a resampling to 25 Hz
// makes 990,001 frames (about 390 MB of floats) of.
std::string hour_long_frames_bvh() { return replaced(h36m_bvh(12), "Frame Time: 0.04", "Frame Time: 3600"); }

using test::ProcessCost;
using test::process_cost;

// Runs `requests`, then checks what they cost the server: its peak
// resident memory grew by less than 1 MiB and it spent less than 200 ms of
// CPU on them (the resampling alone took 3.5 s and 374 MiB a request).
// Prints the cost and the median latency.
void expect_cheap(const test::ServerProcess& server, const std::string& what, int requests,
                  const std::function<void()>& request) {
  const ProcessCost before = process_cost(server.pid());
  std::vector<double> latencies_ms;
  for (int i = 0; i < requests; ++i) {
    const auto started = std::chrono::steady_clock::now();
    request();
    latencies_ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count());
  }
  const ProcessCost after = process_cost(server.pid());
  std::sort(latencies_ms.begin(), latencies_ms.end());
  std::printf("[ cost     ] %s: %d requests, peak RSS %+ld KiB, CPU %.0f ms, median latency %.1f ms\n", what.c_str(),
              requests, after.peak_rss_kib - before.peak_rss_kib, 1000 * (after.cpu_seconds - before.cpu_seconds),
              latencies_ms[latencies_ms.size() / 2]);
  EXPECT_LT(after.peak_rss_kib - before.peak_rss_kib, 1024) << what;
  EXPECT_LT(after.cpu_seconds - before.cpu_seconds, 0.2) << what;
}

// One request written as it is on a new connection, and what the server
// answers within `timeout_s`: the status (0 when nothing came) and the
// whole answer. The timeout is below the 5 s for which httplib waits for a
// body that does not come, so an answer within it was given at once.
struct RawAnswer {
  int status = 0;
  std::string text;
};

RawAnswer raw_request(int port, const std::string& request, int timeout_s = 3) {
  RawAnswer answer;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return answer;
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval timeout{timeout_s, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
    char buffer[4096];
    for (;;) {
      const size_t end = answer.text.find("\r\n\r\n");
      if (end != std::string::npos) {
        const size_t length_at = answer.text.find("Content-Length: ");
        const size_t length = length_at < end ? std::stoul(answer.text.substr(length_at + 16)) : 0;
        if (answer.text.size() >= end + 4 + length) break;
      }
      const ssize_t n = read(fd, buffer, sizeof buffer);
      if (n <= 0) break;
      answer.text.append(buffer, static_cast<size_t>(n));
    }
  }
  close(fd);
  if (answer.text.rfind("HTTP/1.1 ", 0) == 0) answer.status = std::atoi(answer.text.c_str() + 9);
  return answer;
}

std::string headers_only(const std::string& target, const std::string& content_type, const std::string& length) {
  return "POST " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: " + content_type +
         "\r\nContent-Length: " + length + "\r\n\r\n";
}

void expect_still_serving(int port) { EXPECT_EQ(test::get(port, "/healthz").status, 200); }

// One server for the suite, with a data root holding the hour-long BVH.
class BoundedWork : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scratch_ = new test::ScratchDir();
    const fs::path root = scratch_->path() / "data";
    fs::create_directories(root);
    std::ofstream(root / "hours.bvh") << hour_long_frames_bvh();
    // Declares 2,000,000 frames of 0.04 s (22 h) and holds 12.
    std::ofstream(root / "long_take.bvh") << replaced(h36m_bvh(12), "Frames: 12", "Frames: 2000000");
    // 12 frames of a second: 276 frames at 25 Hz, windows from frames 0 to 5.
    std::ofstream(root / "slow.bvh") << replaced(h36m_bvh(12), "Frame Time: 0.04", "Frame Time: 1");
    server_ = new test::ServerProcess({"--data-root", root.string()});
  }
  static void TearDownTestSuite() {
    delete server_;
    delete scratch_;
    server_ = nullptr;
    scratch_ = nullptr;
  }
  static int port() { return server_->rest_port(); }

  static test::ScratchDir* scratch_;
  static test::ServerProcess* server_;
};
test::ScratchDir* BoundedWork::scratch_ = nullptr;
test::ServerProcess* BoundedWork::server_ = nullptr;

TEST_F(BoundedWork, ABvhBodyOfHourLongFramesIsRefusedBeforeItIsResampled) {
  const std::string body = hour_long_frames_bvh();
  EXPECT_LT(body.size(), 13000u);
  // The route's own costs (a connection, a refused body) are paid once first.
  EXPECT_EQ(test::post(port(), "/v1/encode", "HIERARCHY\n", {}, "application/x-bvh").status, 400);
  for (const char* route : {"/v1/encode", "/v1/denoise"}) {
    expect_cheap(*server_, std::string(route) + " of the 12.7 kB BVH", 4, [&] {
      const test::Reply reply = test::post(port(), route, body, {}, "application/x-bvh");
      EXPECT_EQ(reply.status, 400) << reply.body;
      ASSERT_TRUE(reply.document.is_object()) << reply.body;
      const std::string message = reply.error()["message"];
      EXPECT_NE(message.find("frame time 3600 s, expected 0.001 to 1 s"), std::string::npos) << message;
    });
  }
  expect_still_serving(port());
}

TEST_F(BoundedWork, ReadClipOfTheSameFileIsRefusedAsCheaply) {
  EXPECT_EQ(test::get(port(), "/v1/clips/window?path=missing.bvh").status, 404);
  expect_cheap(*server_, "ReadClip of the 12.7 kB BVH", 4, [&] {
    const test::Reply reply = test::get(port(), "/v1/clips/window?path=hours.bvh");
    EXPECT_EQ(reply.status, 400) << reply.body;
    ASSERT_TRUE(reply.document.is_object()) << reply.body;
    EXPECT_EQ(reply.field(), "path");
    const std::string message = reply.error()["message"];
    EXPECT_NE(message.find("hours.bvh:"), std::string::npos) << message;
    EXPECT_NE(message.find("frame time 3600 s"), std::string::npos) << message;
  });
}

// The declared length decides before the frames are read: a body longer
// than the model's clip, a file longer than the longest take; a shorter body
// is refused before it is resampled; a window of a slow file is read.
TEST_F(BoundedWork, LengthsAreCheckedAgainstTheirNamedLimitBeforeTheFramesAreRead) {
  const std::string long_take = replaced(h36m_bvh(12), "Frames: 12", "Frames: 2000000");
  test::Reply reply = test::post(port(), "/v1/encode", long_take, {}, "application/x-bvh");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.body.find("2000000 frames of 0.04 s make 2000000 frames at 25 Hz, more than the 150 of the "
                            "model's clip (6 s at 25 Hz)"),
            std::string::npos)
      << reply.body;
  const std::string slow = replaced(h36m_bvh(12), "Frame Time: 0.04", "Frame Time: 1");
  reply = test::post(port(), "/v1/encode", slow, {}, "application/x-bvh");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.body.find("make 276 frames at 25 Hz, more than the 150"), std::string::npos) << reply.body;
  reply = test::post(port(), "/v1/encode", h36m_bvh(10), {}, "application/x-bvh");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.body.find("10 frames of 0.04 s make 10 frames at 25 Hz, expected the 150"), std::string::npos)
      << reply.body;
  reply = test::post(port(), "/v1/encode", h36m_bvh(150), {}, "application/x-bvh");
  EXPECT_EQ(reply.status, 200) << reply.body;

  reply = test::get(port(), "/v1/clips/window?path=long_take.bvh");
  EXPECT_EQ(reply.status, 400) << reply.body;
  EXPECT_NE(reply.body.find("more than the 1000000 of the longest take (11.1 h)"), std::string::npos) << reply.body;
  reply = test::get(port(), "/v1/clips/window?path=slow.bvh&start=5");
  ASSERT_EQ(reply.status, 200) << reply.body;
  EXPECT_EQ(reply.document["last_start"], 5);
  EXPECT_EQ(reply.document["motion"]["frames"], 150);
  EXPECT_EQ(reply.document["motion"]["values"].size(), 150u * kH36mColumns);
}

TEST_F(BoundedWork, ANegativeContentLengthIs400AtOnce) {
  for (const std::string length : {"-1", "12abc", "99999999999999999999999"}) {
    const RawAnswer answer = raw_request(port(), headers_only("/v1/encode", "application/json", length));
    EXPECT_EQ(answer.status, 400) << length << ": " << answer.text;
    EXPECT_NE(answer.text.find("Content-Length \\\"" + length + "\\\" is not a length in bytes"), std::string::npos)
        << answer.text;
  }
  // A route that takes no body, or none at all, reads none either.
  EXPECT_EQ(raw_request(port(), headers_only("/v1/no-such-route", "application/json", "-1")).status, 404);
  expect_still_serving(port());
}

// Only the headers are sent; the answer comes without the body.
TEST_F(BoundedWork, ADeclaredLengthOverTheRoutesLimitIs413BeforeTheBodyIsSent) {
  struct Case {
    std::string target, content_type, length, limit;
  };
  const std::vector<Case> cases = {
      {"/v1/encode", "application/json", "50000000", "the limit of 33554432 bytes of POST /v1/encode (--max-json-bytes)"},
      {"/v1/decode", "application/json", "40000000", "(--max-json-bytes)"},
      {"/v1/sample", "application/json", "2000000", "the limit of 1048576 bytes of POST /v1/sample (a body of parameters only)"},
      {"/v1/encode", "application/x-bvh", "100000000", "the limit of 67108864 bytes of POST /v1/encode (--max-message-bytes)"},
      {"/v1/clips:upload?path=a.bvh", "application/octet-stream", "1000000000000", "(--max-message-bytes)"},
  };
  for (const Case& c : cases) {
    const RawAnswer answer = raw_request(port(), headers_only(c.target, c.content_type, c.length));
    EXPECT_EQ(answer.status, 413) << c.target << ": " << answer.text;
    EXPECT_NE(answer.text.find("RESOURCE_EXHAUSTED"), std::string::npos) << answer.text;
    EXPECT_NE(answer.text.find(c.length + " bytes (Content-Length) exceeds"), std::string::npos) << answer.text;
    EXPECT_NE(answer.text.find(c.limit), std::string::npos) << answer.text;
  }
  expect_still_serving(port());
}

// A chunked body declares no length: it is cut off where it passes the
// route's limit, JSON's here, and the rest is dropped.
TEST(BoundedWorkLimits, AChunkedJsonBodyIsCutAtTheJsonLimitAndABvhBodyIsNot) {
  test::ServerProcess server({"--max-json-bytes", "100000", "--max-message-bytes", "1000000"});
  std::signal(SIGPIPE, SIG_IGN);
  const auto chunked = [&](const std::string& chunk, size_t chunks, const char* type) {
    auto client = test::rest_client(server.rest_port());
    return test::to_reply(client.Post(
        "/v1/encode",
        [&, chunks](size_t offset, httplib::DataSink& sink) {
          if (offset >= chunks * chunk.size()) {
            sink.done();
            return true;
          }
          return sink.write(chunk.data(), chunk.size());
        },
        type));
  };
  const test::Reply json_reply = chunked(std::string(10000, ' '), 20, "application/json");
  EXPECT_EQ(json_reply.status, 413) << json_reply.body;
  EXPECT_NE(json_reply.body.find("exceeds the limit of 100000 bytes of POST /v1/encode (--max-json-bytes)"),
            std::string::npos)
      << json_reply.body;
  // 200 kB of BVH is within --max-message-bytes: read, and refused as BVH.
  const test::Reply bvh_reply = chunked(std::string(10000, ' '), 20, "application/x-bvh");
  EXPECT_EQ(bvh_reply.status, 400) << bvh_reply.body;
  EXPECT_NE(bvh_reply.body.find("empty file"), std::string::npos) << bvh_reply.body;
  // The JSON limit applies to a declared length as well, and JSON within it is read.
  const RawAnswer declared = raw_request(server.rest_port(), headers_only("/v1/analogy", "application/json", "100001"));
  EXPECT_EQ(declared.status, 413) << declared.text;
  EXPECT_EQ(test::post(server.rest_port(), "/v1/sample", json{{"count", 1}, {"seed", 3}}).status, 200);
}

// Each limit holds at its exact value: the limit itself is answered, one
// past it refused naming the field and the limit (an off-by-one in either
// direction fails here, where requests far over the limit would not see it).
TEST(BoundedWorkLimits, EveryLimitHoldsAtItsExactBoundary) {
  // Denoising rounds at a small limit of their own: 32 rounds of the
  // default would cost 10 s here, and the check is the same.
  test::ServerProcess server({"--max-json-bytes", "100000", "--max-denoise-iterations", "3"});
  const int port = server.rest_port();
  const auto expect_refused = [&](const std::string& target, const json& body, const std::string& field,
                                  const std::string& limit) {
    const test::Reply reply = test::post(port, target, body);
    EXPECT_EQ(reply.status, 413) << target << " " << field << ": " << reply.body;
    EXPECT_EQ(reply.error()["code"], "RESOURCE_EXHAUSTED") << reply.body;
    EXPECT_EQ(reply.field(), field) << reply.body;
    EXPECT_NE(reply.body.find(limit), std::string::npos) << target << ": " << reply.body;
  };
  EXPECT_EQ(test::post(port, "/v1/sample", json{{"count", 64}, {"seed", 1}}).status, 200);
  expect_refused("/v1/sample", json{{"count", 65}, {"seed", 1}}, "count", "at most 64 allowed");

  const std::vector<float> code(64, 0.1f);
  EXPECT_EQ(test::post(port, "/v1/decode", json{{"codes", std::vector<std::vector<float>>(64, code)}}).status, 200);
  expect_refused("/v1/decode", json{{"codes", std::vector<std::vector<float>>(65, code)}}, "codes", "at most 64 allowed");

  const json ends = {{"from", {{"code", code}}}, {"to", {{"code", std::vector<float>(64, -0.1f)}}}};
  json steps = ends;
  steps["steps"] = 64;
  EXPECT_EQ(test::post(port, "/v1/interpolate", steps).status, 200);
  steps["steps"] = 65;
  expect_refused("/v1/interpolate", steps, "steps", "at most 64 allowed");

  MotionFrames still;
  still.values.assign(150 * static_cast<size_t>(kH36mColumns), 0.0f);
  for (int f = 0; f < 150; ++f)
    for (int c = 3; c < kH36mColumns; ++c) still.frame(f)[c] = 0.125f * static_cast<float>((f + c) % 7);
  // Binary fractions print short, so a motion's JSON fits the small limit.
  const json motion = {{"columns", kH36mColumns}, {"frames", 150},          {"frame_rate", 25},
                       {"layout", "h36m-expmap-99"}, {"values", still.values}};
  EXPECT_EQ(test::post(port, "/v1/denoise", json{{"motions", {motion}}, {"iterations", 3}}).status, 200);
  expect_refused("/v1/denoise", json{{"motions", {motion}}, {"iterations", 4}}, "iterations", "at most 3 allowed");

  // A JSON body of exactly --max-json-bytes is read; one byte more is not.
  // (Encode's limit: Sample's body of parameters has its own 1 MiB.)
  const std::string encode_body = json{{"motions", {motion}}}.dump();
  ASSERT_LT(encode_body.size(), 100000u);
  const std::string at_limit = encode_body + std::string(100000 - encode_body.size(), ' ');
  test::Reply reply = test::post(port, "/v1/encode", at_limit, {}, "application/json");
  EXPECT_EQ(reply.status, 200) << reply.body.substr(0, 300);
  reply = test::post(port, "/v1/encode", at_limit + " ", {}, "application/json");
  EXPECT_EQ(reply.status, 413) << reply.body.substr(0, 300);
  EXPECT_NE(reply.body.find("100001 bytes (Content-Length) exceeds the limit of 100000 bytes"), std::string::npos)
      << reply.body;
}

}  // namespace
}  // namespace mm
