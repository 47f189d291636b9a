// Takes over the wire, end to end: the real motion-manifold-server on
// loopback, called through the generated gRPC stubs (client-streamed takes,
// server-streamed replies) and over REST (motion text, BVH, JSON). Whole
// H3.6M files at their 50 Hz, a 120 Hz BVH of the H3.6M skeleton, a CMU
// dance at 120 Hz through a model of that rig, NaN gaps filled by
// DenoiseTake, an hour-long take streamed through a server whose peak memory
// is read from /proc, and bad input refused naming the field with nothing
// left behind (the take slot given back, the memory back where it was).
// Timings are printed, never asserted.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "format/bvh_file.h"
#include "format/expmap_slerp.h"
#include "format/foot_contacts.h"
#include "format/motion_resampling.h"
#include "format/motion_text.h"
#include "format/skeleton.h"
#include "format/skeleton_bvh.h"
#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "tests/common/cmu_dance.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::motionmanifold::v1;
using grpc::StatusCode;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr int kColumns = 99;
constexpr int kChunkFrames = 1000;  // frames a request chunk carries

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Every S5 file of the H3.6M copy, by name, read once.
const std::map<std::string, MotionFrames>& s5_files() {
  static const std::map<std::string, MotionFrames> files = [] {
    std::map<std::string, MotionFrames> read;
    for (const auto& entry : fs::directory_iterator(h36m_dataset_dir() / "S5")) {
      if (entry.path().extension() == ".txt") {
        read.emplace(entry.path().filename().string(), read_motion_text(entry.path().string()));
      }
    }
    return read;
  }();
  return files;
}
const MotionFrames& s5(const std::string& name) { return s5_files().at(name); }

std::string motion_text(const MotionFrames& motion) {
  std::ostringstream out;
  write_motion_text(motion, out);
  return out.str();
}

// The first `frames` frames of `motion`.
MotionFrames head(const MotionFrames& motion, int64_t frames) {
  MotionFrames out;
  out.columns = motion.columns;
  out.values.assign(motion.values.begin(), motion.values.begin() + frames * motion.columns);
  return out;
}

// CPU seconds a process has spent, all its threads (/proc/PID/stat): what a
// take cost the server, whatever else the machine was doing.
double cpu_seconds_of(pid_t pid) {
  std::ifstream stat_file("/proc/" + std::to_string(pid) + "/stat");
  const std::string stat((std::istreambuf_iterator<char>(stat_file)), {});
  // The name in parentheses may hold spaces; utime and stime are the 12th
  // and 13th fields after it.
  std::istringstream fields(stat.substr(stat.rfind(')') + 1));
  std::vector<std::string> after_name{std::istream_iterator<std::string>(fields), {}};
  if (after_name.size() <= 12) return 0;
  return static_cast<double>(std::stoll(after_name[11]) + std::stoll(after_name[12])) /
         static_cast<double>(sysconf(_SC_CLK_TCK));
}

// Resident memory of a process now and at its peak, KiB (/proc/PID/status).
struct Memory {
  long rss_kib = 0;
  long peak_kib = 0;
};
Memory memory_of(pid_t pid) {
  Memory memory;
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) memory.rss_kib = std::stol(line.substr(6));
    if (line.rfind("VmHWM:", 0) == 0) memory.peak_kib = std::stol(line.substr(6));
  }
  return memory;
}

// ------------------------------------------------------------------ gRPC

std::unique_ptr<v1::MotionManifold::Stub> stub_of(const ServerProcess& server) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  return v1::MotionManifold::NewStub(
      grpc::CreateCustomChannel(server.grpc_target(), grpc::InsecureChannelCredentials(), args));
}

// The chunks of a take after its header: fills `chunk` and returns true, or
// returns false at the end.
using ChunkSource = std::function<bool(v1::FrameChunk* chunk)>;

ChunkSource chunks_of(const MotionFrames& motion, int chunk_frames = kChunkFrames) {
  auto next = std::make_shared<int64_t>(0);
  return [&motion, next, chunk_frames](v1::FrameChunk* chunk) {
    const int64_t total = motion.frame_count();
    if (*next >= total) return false;
    const int64_t count = std::min<int64_t>(chunk_frames, total - *next);
    chunk->set_frames(static_cast<int32_t>(count));
    chunk->mutable_values()->Add(motion.frame(*next), motion.frame(*next) + count * motion.columns);
    *next += count;
    return true;
  };
}

v1::TakeHeader take_header(double rate) {
  v1::TakeHeader header;
  header.set_frame_rate(rate);
  header.set_columns(kColumns);
  return header;
}

// A streamed take's reply: what came back and how the call ended.
struct StreamedTake {
  grpc::Status status;
  std::string error_field;  // mm-error-field of a refusal
  v1::TakeOutputHeader header;
  std::vector<float> values;  // kept only when asked
  std::vector<float> error_mm;
  int64_t frames = 0;          // in the reply's chunks
  int64_t largest_chunk = 0;   // frames of the largest reply chunk
  bool values_finite = true;   // every reply value and error is finite
  v1::TakeSummary summary;
  int header_messages = 0, summary_messages = 0;
  double seconds = 0;
};

std::string error_field(const grpc::ClientContext& context) {
  const auto& trailing = context.GetServerTrailingMetadata();
  const auto found = trailing.find("mm-error-field");
  return found == trailing.end() ? "" : std::string(found->second.data(), found->second.size());
}

// ReconstructTake or DenoiseTake: the header, then the chunks of `source`
// written on a thread of their own while the reply is read here (a take of
// an hour does not fit the flow-control windows).
StreamedTake stream_take(v1::MotionManifold::Stub& stub, bool denoise, const v1::TakeHeader& header,
                         const ChunkSource& source, bool keep_values = true) {
  StreamedTake take;
  const auto started = Clock::now();
  grpc::ClientContext context;
  auto stream = denoise ? stub.DenoiseTake(&context) : stub.ReconstructTake(&context);
  std::thread writer([&] {
    v1::TakeInput message;
    *message.mutable_header() = header;
    if (!stream->Write(message)) return;
    for (;;) {
      v1::TakeInput chunk;
      if (!source(chunk.mutable_chunk())) break;
      if (!stream->Write(chunk)) return;
    }
    stream->WritesDone();
  });
  v1::TakeOutput output;
  while (stream->Read(&output)) {
    if (output.has_header()) {
      take.header = output.header();
      ++take.header_messages;
    } else if (output.has_chunk()) {
      const v1::FrameChunk& chunk = output.chunk();
      take.frames += chunk.frames();
      take.largest_chunk = std::max<int64_t>(take.largest_chunk, chunk.frames());
      for (float v : chunk.values()) take.values_finite = take.values_finite && std::isfinite(v);
      for (float v : chunk.error_mm()) take.values_finite = take.values_finite && std::isfinite(v);
      if (keep_values) {
        take.values.insert(take.values.end(), chunk.values().begin(), chunk.values().end());
        take.error_mm.insert(take.error_mm.end(), chunk.error_mm().begin(), chunk.error_mm().end());
      }
    } else if (output.has_summary()) {
      take.summary = output.summary();
      ++take.summary_messages;
    }
  }
  writer.join();
  take.status = stream->Finish();
  take.error_field = error_field(context);
  take.seconds = seconds_since(started);
  return take;
}

StreamedTake reconstruct(v1::MotionManifold::Stub& stub, const MotionFrames& motion, double rate,
                         double hop_seconds = 0) {
  v1::TakeHeader header = take_header(rate);
  header.set_hop_seconds(hop_seconds);
  return stream_take(stub, false, header, chunks_of(motion));
}

// EncodeTake: the code track, or the refusal.
struct EncodedTake {
  grpc::Status status;
  std::string error_field;
  v1::CodeTrack track;
};
EncodedTake encode_take(v1::MotionManifold::Stub& stub, const std::vector<v1::TakeInput>& messages) {
  EncodedTake encoded;
  grpc::ClientContext context;
  auto writer = stub.EncodeTake(&context, &encoded.track);
  for (const auto& message : messages) {
    if (!writer->Write(message)) break;
  }
  writer->WritesDone();
  encoded.status = writer->Finish();
  encoded.error_field = error_field(context);
  return encoded;
}

v1::TakeInput header_message(const v1::TakeHeader& header) {
  v1::TakeInput message;
  *message.mutable_header() = header;
  return message;
}
v1::TakeInput chunk_message(const float* values, int64_t frames, int columns = kColumns) {
  v1::TakeInput message;
  message.mutable_chunk()->set_frames(static_cast<int32_t>(frames));
  message.mutable_chunk()->mutable_values()->Add(values, values + frames * columns);
  return message;
}
std::vector<v1::TakeInput> take_messages(const MotionFrames& motion, double rate) {
  std::vector<v1::TakeInput> messages = {header_message(take_header(rate))};
  for (int64_t first = 0; first < motion.frame_count(); first += kChunkFrames) {
    messages.push_back(chunk_message(motion.frame(first), std::min<int64_t>(kChunkFrames, motion.frame_count() - first)));
  }
  return messages;
}

void expect_refused(const grpc::Status& status, const std::string& field, StatusCode code, const std::string& field_expected,
                    const std::string& what) {
  EXPECT_EQ(status.error_code(), code) << what << ": " << status.error_message();
  EXPECT_EQ(field, field_expected) << what << ": " << status.error_message();
}

// ------------------------------------------------------------------ REST

Reply post_take(int port, const std::string& target, const std::string& body, const std::string& content_type,
                const std::string& accept) {
  return post(port, target, body, {{"Accept", accept}}, content_type);
}

// The frames of a motion-text reply.
MotionFrames parse_text_reply(const std::string& body, int columns = kColumns) {
  return parse_motion_text_buffer(body.data(), body.size(), "reply", columns);
}

// A request written as it is on a new connection, and what is answered
// until the server closes it (empty when nothing came within 3 s).
std::string raw_answer(int port, const std::string& request) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return "";
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  timeval timeout{3, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  std::string answer;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0 &&
      write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
    char buffer[4096];
    ssize_t n;
    // The refusal closes the connection: read to its end.
    while ((n = read(fd, buffer, sizeof buffer)) > 0) answer.append(buffer, static_cast<size_t>(n));
  }
  close(fd);
  return answer;
}

// ------------------------------------------------------------------ suite

// One server with the shipped models for the suite's ordinary takes.
class TakesService : public ::testing::Test {
 protected:
  // One executor thread: ctest runs two suites at once on two cores, where
  // OpenMP threads spinning beside another suite slow a take several times.
  static void SetUpTestSuite() { server_ = new ServerProcess({"--threads", "1"}); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static ServerProcess& server() { return *server_; }
  static ServerProcess* server_;
};
ServerProcess* TakesService::server_ = nullptr;

// Every whole S5 file, any length, through the default model at its own
// 50 Hz: as many frames come back as went in, at the same rate, in chunks
// of at most 2048 frames, each with its error. A hop of 6 s (windows side
// by side) halves the suite's time; the other tests join overlapping ones.
TEST_F(TakesService, EveryS5FileComesBackWithItsFramesAndRateOverGrpc) {
  auto stub = stub_of(server());
  double motion_seconds = 0, wall_seconds = 0, cpu_seconds = 0;
  for (const auto& [name, motion] : s5_files()) {
    const double cpu_before = cpu_seconds_of(server().pid());
    const StreamedTake take = reconstruct(*stub, motion, 50, 6.0);
    const double cpu = cpu_seconds_of(server().pid()) - cpu_before;
    ASSERT_TRUE(take.status.ok()) << name << ": " << take.status.error_message();
    EXPECT_EQ(take.header_messages, 1) << name;
    EXPECT_EQ(take.summary_messages, 1) << name;
    EXPECT_EQ(take.header.frame_rate(), 50) << name;
    EXPECT_EQ(take.header.columns(), kColumns) << name;
    EXPECT_EQ(take.frames, motion.frame_count()) << name;
    EXPECT_EQ(static_cast<int64_t>(take.values.size()), motion.frame_count() * kColumns) << name;
    EXPECT_EQ(static_cast<int64_t>(take.error_mm.size()), motion.frame_count()) << name;
    EXPECT_LE(take.largest_chunk, 2048) << name;
    EXPECT_TRUE(take.values_finite) << name;
    EXPECT_EQ(take.summary.frames(), motion.frame_count()) << name;
    EXPECT_EQ(take.summary.input_frames(), motion.frame_count()) << name;
    EXPECT_GT(take.summary.windows_size(), 0) << name;
    // The root translation is the input's, copied.
    for (int64_t f = 0; f < motion.frame_count(); f += 97) {
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(take.values[f * kColumns + c], motion.frame(f)[c], 1e-4) << name << " " << f;
    }
    const double seconds = (motion.frame_count() - 1) / 50.0;
    motion_seconds += seconds;
    wall_seconds += take.seconds;
    cpu_seconds += cpu;
    std::printf("[ take     ] %-24s %5lld frames (%5.1f s at 50 Hz): %5.2f s wall, %5.2f s server CPU, error mean %5.1f "
                "max %5.1f mm, %2d windows\n",
                name.c_str(), static_cast<long long>(motion.frame_count()), seconds, take.seconds, cpu,
                take.summary.mean_error_mm(), take.summary.max_error_mm(), take.summary.windows_size());
  }
  EXPECT_EQ(s5_files().size(), 24u);
  std::printf("[ take     ] all of S5: %.0f s of motion in %.1f s wall, %.1f s of server CPU\n", motion_seconds,
              wall_seconds, cpu_seconds);
}

// An S5 file over REST: motion text in; JSON, motion text and BVH out,
// each as long as the input at its rate; the code track of encode.
TEST_F(TakesService, S5FilesOverRestComeBackAsJsonTextAndBvh) {
  const int port = server().rest_port();
  for (const std::string name : {"walking_1.txt"}) {
    const MotionFrames& motion = s5(name);
    const std::string body = motion_text(motion);
    auto started = Clock::now();
    const Reply as_json = post_take(port, "/v1/takes:reconstruct", body, "text/plain", "application/json");
    ASSERT_EQ(as_json.status, 200) << as_json.body.substr(0, 500);
    std::printf("[ rest     ] %s reconstruct to JSON: %.2f s\n", name.c_str(), seconds_since(started));
    EXPECT_EQ(as_json.document["frames"], motion.frame_count());
    EXPECT_EQ(as_json.document["frame_rate"], 50);
    EXPECT_EQ(as_json.document["columns"], kColumns);
    EXPECT_EQ(as_json.document["layout"], "h36m-expmap-99");
    EXPECT_EQ(as_json.document["values"].size(), static_cast<size_t>(motion.frame_count() * kColumns));
    EXPECT_EQ(as_json.document["error_mm"].size(), static_cast<size_t>(motion.frame_count()));
    EXPECT_EQ(as_json.document["summary"]["frames"], motion.frame_count());
    EXPECT_FALSE(as_json.document["windows"].empty());

    const Reply as_text = post_take(port, "/v1/takes:reconstruct?hop_seconds=6", body, "text/plain", "text/plain");
    ASSERT_EQ(as_text.status, 200) << as_text.body.substr(0, 500);
    EXPECT_EQ(parse_text_reply(as_text.body).frame_count(), motion.frame_count());
    EXPECT_EQ(as_text.header("X-Take-Frames"), std::to_string(motion.frame_count()));
    EXPECT_EQ(as_text.header("X-Take-Frame-Rate"), "50");
    EXPECT_FALSE(as_text.header("X-Take-Mean-Error-Mm").empty());
    EXPECT_FALSE(as_text.header("X-Take-Windows").empty());

    const Reply as_bvh = post_take(port, "/v1/takes:reconstruct?blend=cut&hop_seconds=4.5", body, "text/plain", "application/x-bvh");
    ASSERT_EQ(as_bvh.status, 200) << as_bvh.body.substr(0, 500);
    const BvhFile file = parse_bvh_text(as_bvh.body, "reply.bvh");
    EXPECT_EQ(file.frame_count(), motion.frame_count());
    EXPECT_NEAR(file.frame_time_s, 0.02, 1e-9);

    const Reply encoded = post_take(port, "/v1/takes:encode", body, "text/plain", "application/json");
    ASSERT_EQ(encoded.status, 200) << encoded.body.substr(0, 500);
    EXPECT_EQ(encoded.document["frames"], motion.frame_count());
    EXPECT_EQ(encoded.document["frame_rate"], 50);
    EXPECT_EQ(encoded.document["window_seconds"], 6);
    ASSERT_FALSE(encoded.document["windows"].empty());
    EXPECT_EQ(encoded.document["windows"][0]["start_seconds"], 0);
    EXPECT_EQ(encoded.document["windows"][0]["code"].size(), 64u);

    // The track decoded back: one motion of the track's length at 25 Hz.
    const json track = {{"windows", encoded.document["windows"]}, {"frame_rate", 25}};
    const Reply decoded = post(port, "/v1/tracks:decode", track, {{"Accept", "text/plain"}});
    ASSERT_EQ(decoded.status, 200) << decoded.body.substr(0, 500);
    const double last_start = encoded.document["windows"].back()["start_seconds"].get<double>();
    EXPECT_EQ(parse_text_reply(decoded.body).frame_count(), std::llround(last_start * 25) + 150);
  }
}

// The H3.6M skeleton as a 120 Hz BVH (an S5 file brought to 120 Hz by the
// library's resampling and exported): a 120 Hz BVH of the same frame count
// comes back, over REST as BVH and over gRPC as frames at 120 Hz.
TEST_F(TakesService, A120HzBvhOfTheH36mSkeletonComesBackAt120HzOverBothProtocols) {
  const Skeleton skeleton = Skeleton::h36m();
  const MotionFrames at_120 = resample_motion(head(s5("walking_1.txt"), 1500), 50, 120);
  const std::string bvh = write_bvh_text(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), at_120, 120));
  const Reply reply = post_take(server().rest_port(), "/v1/takes:reconstruct", bvh, "application/x-bvh", "application/x-bvh");
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const BvhFile out = parse_bvh_text(reply.body, "reply.bvh");
  EXPECT_EQ(out.frame_count(), at_120.frame_count());
  EXPECT_NEAR(out.frame_time_s, 1.0 / 120, 1e-9);
  EXPECT_EQ(reply.header("X-Take-Frame-Rate"), "120");

  // The client side of gRPC reads the BVH at its own rate and streams it.
  const BvhFile in = parse_bvh_text(bvh, "take.bvh");
  const MotionFrames frames = skeleton_motion_from_bvh_at_file_rate(skeleton, in, "take.bvh");
  auto stub = stub_of(server());
  const StreamedTake take = reconstruct(*stub, frames, 1.0 / in.frame_time_s);
  ASSERT_TRUE(take.status.ok()) << take.status.error_message();
  EXPECT_NEAR(take.header.frame_rate(), 120, 1e-6);
  EXPECT_EQ(take.frames, frames.frame_count());
  MotionFrames reply_frames;
  reply_frames.values = take.values;
  const BvhFile written = parse_bvh_text(
      write_bvh_text(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), reply_frames, take.header.frame_rate())),
      "reply.bvh");
  EXPECT_EQ(written.frame_count(), in.frame_count());
  EXPECT_NEAR(written.frame_time_s, in.frame_time_s, 1e-9);
}

// A BVH take whose root starts away from the origin (as a capture's does)
// comes back where it was: the reply's root follows the input's absolute
// positions over REST (BVH in and out) and over gRPC (the client's import
// of the BVH, the reply exported again), not restarted at the origin.
TEST_F(TakesService, ABvhTakeKeepsItsAbsoluteRootOverBothProtocols) {
  const Skeleton skeleton = Skeleton::h36m();
  MotionFrames at_60 = resample_motion(head(s5("walking_1.txt"), 600), 50, 60);
  at_60.frame(0)[0] = 1234.5f;  // the capture's start, mm
  at_60.frame(0)[2] = -876.0f;
  const std::string bvh = write_bvh_text(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), at_60, 60));
  const BvhFile in = parse_bvh_text(bvh, "take.bvh");
  const Reply reply = post_take(server().rest_port(), "/v1/takes:reconstruct", bvh, "application/x-bvh", "application/x-bvh");
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const BvhFile out = parse_bvh_text(reply.body, "reply.bvh");
  ASSERT_EQ(out.frame_count(), in.frame_count());
  double largest = 0;
  for (int64_t f = 0; f < in.frame_count(); f += 17) {
    const auto want = bvh_world_positions(in, f)[0], got = bvh_world_positions(out, f)[0];
    for (int a = 0; a < 3; ++a) largest = std::max(largest, std::fabs(got[a] - want[a]));
  }
  EXPECT_LT(largest, 1.0) << "mm, REST";
  EXPECT_NEAR(bvh_world_positions(out, 0)[0][0], 1234.5, 1.0);

  const MotionFrames frames = skeleton_motion_from_bvh_at_file_rate(skeleton, in, "take.bvh");
  auto stub = stub_of(server());
  const StreamedTake take = reconstruct(*stub, frames, 60);
  ASSERT_TRUE(take.status.ok()) << take.status.error_message();
  MotionFrames back;
  back.values = take.values;
  const BvhFile written = parse_bvh_text(write_bvh_text(skeleton_motion_to_bvh(skeleton, bvh_layout_of(skeleton), back, 60)),
                                         "reply.bvh");
  largest = 0;
  for (int64_t f = 0; f < in.frame_count(); f += 17) {
    const auto want = bvh_world_positions(in, f)[0], got = bvh_world_positions(written, f)[0];
    for (int a = 0; a < 3; ++a) largest = std::max(largest, std::fabs(got[a] - want[a]));
  }
  EXPECT_LT(largest, 1.0) << "mm, gRPC";
}

// root "generated": the reply's root is the model's trajectory, which
// travels about as far as the recording over 20 s of walking, with the
// lowest foot on the floor; "input" copies the take's; anything else, or a
// model without a trajectory network, is refused naming "root".
TEST_F(TakesService, AGeneratedRootTravelsLikeTheRecordingAndABadRootIsRefusedNamingIt) {
  const MotionFrames walk = head(s5("walking_1.txt"), 1000);
  auto stub = stub_of(server());
  v1::TakeHeader header = take_header(50);
  header.set_root("generated");
  const StreamedTake take = stream_take(*stub, false, header, chunks_of(walk));
  ASSERT_TRUE(take.status.ok()) << take.status.error_message();
  ASSERT_EQ(take.frames, walk.frame_count());
  double recorded = 0, generated = 0;
  for (int64_t f = 1; f < walk.frame_count(); ++f) {
    recorded += std::hypot(walk.frame(f)[0], walk.frame(f)[2]);
    generated += std::hypot(take.values[static_cast<size_t>(f * kColumns)], take.values[static_cast<size_t>(f * kColumns + 2)]);
  }
  std::printf("[ root     ] 20 s of walking: recorded %.0f mm, generated %.0f mm\n", recorded, generated);
  EXPECT_NEAR(generated, recorded, 0.25 * recorded);
  // Over REST the same option is a query parameter.
  const Reply reply = post_take(server().rest_port(), "/v1/takes:reconstruct?root=generated", motion_text(head(walk, 400)),
                                "text/plain", "text/plain");
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const MotionFrames rest = parse_text_reply(reply.body);
  double rest_travel = 0;
  for (int64_t f = 1; f < rest.frame_count(); ++f) rest_travel += std::hypot(rest.frame(f)[0], rest.frame(f)[2]);
  EXPECT_GT(rest_travel, 1000.0);
  const Reply bad = post_take(server().rest_port(), "/v1/takes:reconstruct?root=somewhere", motion_text(head(walk, 400)),
                              "text/plain", "application/json");
  EXPECT_EQ(bad.status, 400);
  EXPECT_NE(bad.body.find("\"field\":\"root\""), std::string::npos) << bad.body;
  header.set_root("somewhere");
  const StreamedTake refused = stream_take(*stub, false, header, chunks_of(head(walk, 400)));
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(refused.error_field, "root");
}

// DenoiseTake fills gaps of 0.5 s on five joints (NaN): nothing missing
// comes back, and with keep_observed every observed value is returned as
// sent (the root translation always is).
TEST_F(TakesService, DenoiseTakeFillsHalfSecondGapsOnFiveJointsAndKeepsTheObservedValues) {
  MotionFrames motion = head(s5("walking_1.txt"), 1500);  // 30 s at 50 Hz
  const int joints[] = {1, 2, 6, 7, 17};
  std::vector<bool> missing(motion.values.size(), false);
  int gaps = 0;
  for (int j = 0; j < 5; ++j) {
    for (int64_t start = 100 + 60 * j; start + 25 <= motion.frame_count(); start += 400) {
      for (int64_t f = start; f < start + 25; ++f) {
        for (int c = 0; c < 3; ++c) {
          const size_t at = static_cast<size_t>(f * kColumns + 3 + 3 * joints[j] + c);
          motion.values[at] = std::numeric_limits<float>::quiet_NaN();
          missing[at] = true;
        }
      }
      ++gaps;
    }
  }
  v1::TakeHeader header = take_header(50);
  header.set_keep_observed(true);
  auto stub = stub_of(server());
  const StreamedTake take = stream_take(*stub, true, header, chunks_of(motion));
  ASSERT_TRUE(take.status.ok()) << take.status.error_message();
  ASSERT_EQ(take.frames, motion.frame_count());
  EXPECT_TRUE(take.values_finite);
  int64_t filled = 0;
  for (size_t i = 0; i < motion.values.size(); ++i) {
    if (missing[i]) {
      ASSERT_TRUE(std::isfinite(take.values[i])) << i;
      ++filled;
    } else {
      ASSERT_NEAR(take.values[i], motion.values[i], 1e-5) << "frame " << i / kColumns << " column " << i % kColumns;
    }
  }
  std::printf("[ denoise  ] %d gaps of 0.5 s in 30 s, %lld values filled in %.2f s\n", gaps,
              static_cast<long long>(filled), take.seconds);
  // The same over REST with nan in motion text.
  const Reply reply = post_take(server().rest_port(), "/v1/takes:denoise?keep_observed=true", motion_text(motion),
                                "text/plain", "text/plain");
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const MotionFrames denoised = parse_text_reply(reply.body);
  ASSERT_EQ(denoised.frame_count(), motion.frame_count());
  for (size_t i = 0; i < motion.values.size(); ++i) {
    ASSERT_TRUE(std::isfinite(denoised.values[i])) << i;
  }
}

// Gaps of every joint in S5 walking_1 at its 50 Hz: `spans` of frames
// (first, last) made NaN in every joint column.
MotionFrames with_every_joint_missing(const MotionFrames& motion, const std::vector<std::pair<int64_t, int64_t>>& spans) {
  MotionFrames gapped = motion;
  for (const auto& [first, last] : spans) {
    for (int64_t f = first; f <= last; ++f) {
      std::fill(gapped.frame(f) + 3, gapped.frame(f) + kColumns, std::numeric_limits<float>::quiet_NaN());
    }
  }
  return gapped;
}

// DenoiseTake with keep_observed over gRPC, gap_fill as given ("": the
// default): the reply's frames, and its summary in `summary` when given.
MotionFrames denoise_keeping_observed(v1::MotionManifold::Stub& stub, const MotionFrames& take, const std::string& gap_fill,
                                      v1::TakeSummary* summary = nullptr) {
  v1::TakeHeader header = take_header(50);
  header.set_keep_observed(true);
  header.set_gap_fill(gap_fill);
  const StreamedTake reply = stream_take(stub, true, header, chunks_of(take));
  EXPECT_TRUE(reply.status.ok()) << reply.status.error_message();
  if (summary != nullptr) *summary = reply.summary;
  MotionFrames frames;
  frames.columns = kColumns;
  frames.values = reply.values;
  return frames;
}

// Mean distance of every joint but the root between two frames' poses, mm.
double pose_distance(const float* a, const float* b) {
  static const Skeleton skeleton = Skeleton::h36m();
  const auto p = pose_positions(skeleton, a), q = pose_positions(skeleton, b);
  double sum = 0;
  for (size_t j = 1; j < p.size(); ++j) {
    sum += std::sqrt((p[j][0] - q[j][0]) * (p[j][0] - q[j][0]) + (p[j][1] - q[j][1]) * (p[j][1] - q[j][1]) +
                     (p[j][2] - q[j][2]) * (p[j][2] - q[j][2]));
  }
  return sum / static_cast<double>(p.size() - 1);
}

// The case (#35) through the service: every joint of walking_1
// missing for 2 s (its frames 1000 to 1099 at 50 Hz). A per-joint slerp
// between the border poses freezes; DenoiseTake's default fill (borrowed:
// the take's stretch most like this gap's surroundings costs 0.0208, past
// the bound of 0.02, so the gap gets the fitted fill), a code fitted to
// the observed frames of a window centred on the gap, walks
// through it nearer the recording, and nearer than the take's own windows'
// movement (gap_fill "matched"). The summary counts the window fitted to
// the gap, none for "matched". Measured: slerp 73.2 mm at 0.14x the
// recording's speed, matched 98.1 mm at 1.00x, fitted 60.5 mm at 1.00x
// (23 s, 31 s of CPU with the next test, at a load of 7 on two cores).
TEST_F(TakesService, DenoiseTakeFillsATwoSecondGapOfEveryJointFromAFittedCodeNearerTheRecordingThanSlerp) {
  const MotionFrames take = head(s5("walking_1.txt"), 1500);  // 30 s
  const int64_t first = 1000, last = 1099;
  const MotionFrames gapped = with_every_joint_missing(take, {{first, last}});
  auto stub = stub_of(server());
  const auto started = Clock::now();
  v1::TakeSummary fitted_summary, matched_summary;
  const MotionFrames fitted = denoise_keeping_observed(*stub, gapped, "", &fitted_summary);
  const double fitted_seconds = seconds_since(started);
  const MotionFrames matched = denoise_keeping_observed(*stub, gapped, "matched", &matched_summary);
  EXPECT_GE(fitted_summary.gap_windows_fitted(), 1);
  EXPECT_GE(fitted_summary.gaps_fitted(), 1);
  EXPECT_EQ(fitted_summary.gaps_over_fit_limit(), 0);
  EXPECT_EQ(matched_summary.gap_windows_fitted(), 0);
  EXPECT_EQ(matched_summary.gaps_fitted(), 0);
  EXPECT_EQ(matched_summary.gaps_over_fit_limit(), 0);
  ASSERT_EQ(fitted.frame_count(), take.frame_count());
  ASSERT_EQ(matched.frame_count(), take.frame_count());
  MotionFrames slerped = gapped;
  for (int64_t f = first; f <= last; ++f) {
    const double t = static_cast<double>(f - (first - 1)) / static_cast<double>(last + 1 - (first - 1));
    for (int c = 3; c < kColumns; c += 3) slerp_expmap(take.frame(first - 1) + c, take.frame(last + 1) + c, t, slerped.frame(f) + c);
  }
  auto mpjpe = [&](const MotionFrames& filled) {
    double sum = 0;
    for (int64_t f = first; f <= last; ++f) sum += pose_distance(filled.frame(f), take.frame(f));
    return sum / static_cast<double>(last - first + 1);
  };
  auto speed = [&](const MotionFrames& filled) {
    double moved = 0, recorded = 0;
    for (int64_t f = first - 1; f <= last; ++f) {
      moved += pose_distance(filled.frame(f), filled.frame(f + 1));
      recorded += pose_distance(take.frame(f), take.frame(f + 1));
    }
    return moved / recorded;
  };
  std::printf("[ gap 2 s  ] slerp %.1f mm at %.2fx the recording's speed; matched %.1f mm at %.2fx; fitted %.1f mm "
              "at %.2fx (%.1f s)\n",
              mpjpe(slerped), speed(slerped), mpjpe(matched), speed(matched), mpjpe(fitted), speed(fitted),
              fitted_seconds);
  EXPECT_LT(mpjpe(fitted), mpjpe(slerped));
  EXPECT_LT(mpjpe(fitted), mpjpe(matched));
  EXPECT_GE(speed(fitted), 0.8);
  EXPECT_LE(speed(fitted), 1.2);
  // The observed frames come back as sent.
  for (int64_t f : {first - 1, last + 1}) {
    for (int c = 3; c < kColumns; ++c) ASSERT_EQ(fitted.frame(f)[c], take.frame(f)[c]) << "frame " << f;
  }
}

// REST's gap_fill is gRPC's: 20 s of walking_1 with every joint missing
// for 2 s, denoised keeping the observed values with gap_fill=slerp, comes
// back over REST (motion text, its 7 decimals) as over gRPC (floats), within
// the text's rounding; the default fill reports the window it fitted to
// the gap in the X-Take-Gap* headers, slerp none. A name the server does
// not know, or gap_fill without keep_observed, is 400 naming gap_fill, as
// gRPC's refusal names it.
TEST_F(TakesService, GapFillOverRestFillsAsOverGrpcAndItsHeadersCountTheFittedGaps) {
  const MotionFrames gapped = with_every_joint_missing(head(s5("walking_1.txt"), 1000), {{500, 599}});
  const std::string body = motion_text(gapped);
  const int port = server().rest_port();
  auto stub = stub_of(server());
  const MotionFrames over_grpc = denoise_keeping_observed(*stub, gapped, "slerp");
  const Reply slerped = post_take(port, "/v1/takes:denoise?keep_observed=true&gap_fill=slerp", body, "text/plain", "text/plain");
  ASSERT_EQ(slerped.status, 200) << slerped.body.substr(0, 500);
  const MotionFrames over_rest = parse_text_reply(slerped.body);
  ASSERT_EQ(over_rest.frame_count(), gapped.frame_count());
  ASSERT_EQ(over_grpc.frame_count(), gapped.frame_count());
  float largest = 0;
  for (size_t i = 0; i < over_rest.values.size(); ++i) {
    const float scale = std::max(1.0f, std::fabs(over_grpc.values[i]));
    largest = std::max(largest, std::fabs(over_rest.values[i] - over_grpc.values[i]) / scale);
  }
  EXPECT_LE(largest, 1e-5f) << "largest difference between REST's and gRPC's slerp fill (relative above 1)";
  EXPECT_EQ(slerped.header("X-Take-Gap-Windows-Fitted"), "0");
  EXPECT_EQ(slerped.header("X-Take-Gaps-Fitted"), "0");
  EXPECT_EQ(slerped.header("X-Take-Gaps-Over-Fit-Limit"), "0");

  const Reply fitted = post_take(port, "/v1/takes:denoise?keep_observed=true", body, "text/plain", "text/plain");
  ASSERT_EQ(fitted.status, 200) << fitted.body.substr(0, 500);
  EXPECT_GE(std::atoi(fitted.header("X-Take-Gap-Windows-Fitted").c_str()), 1);
  EXPECT_GE(std::atoi(fitted.header("X-Take-Gaps-Fitted").c_str()), 1);
  EXPECT_EQ(fitted.header("X-Take-Gaps-Over-Fit-Limit"), "0");

  for (const std::string target : {"/v1/takes:denoise?keep_observed=true&gap_fill=spline", "/v1/takes:denoise?gap_fill=slerp"}) {
    const Reply refused = post_take(port, target, body, "text/plain", "text/plain");
    EXPECT_EQ(refused.status, 400) << target << ": " << refused.body.substr(0, 500);
    EXPECT_EQ(refused.document.is_object() ? refused.field() : "", "gap_fill") << refused.body.substr(0, 500);
  }
}

// A server fitting at most one window a take (--max-take-gap-fits 1): a
// take of three gaps of every joint still answers; the first gap is filled
// from its fitted window, the two later ones exactly as gap_fill "matched"
// fills them, as the summary counts (one window, one gap, two over the
// bound). A gap_fill the server does not know, or one on a call without
// keep_observed, is refused naming gap_fill. 37 s at a load of 8 on two
// cores (the server's start included).
TEST(TakesGapFitBound, GapsBeyondTheServersBoundOfFittedWindowsGetTheMatchedFill) {
  ServerProcess server({"--threads", "1", "--max-take-gap-fits", "1"});
  auto stub = stub_of(server);
  const MotionFrames take = head(s5("walking_1.txt"), 800);  // 16 s
  const std::vector<std::pair<int64_t, int64_t>> gaps = {{100, 149}, {350, 399}, {600, 649}};
  const MotionFrames gapped = with_every_joint_missing(take, gaps);
  v1::TakeSummary bounded;
  const MotionFrames fitted = denoise_keeping_observed(*stub, gapped, "fitted", &bounded);
  const MotionFrames matched = denoise_keeping_observed(*stub, gapped, "matched");
  EXPECT_EQ(bounded.gap_windows_fitted(), 1);
  EXPECT_EQ(bounded.gaps_fitted(), 1);
  EXPECT_EQ(bounded.gaps_over_fit_limit(), 2);
  ASSERT_EQ(fitted.frame_count(), take.frame_count());
  ASSERT_EQ(matched.frame_count(), take.frame_count());
  for (size_t g = 0; g < gaps.size(); ++g) {
    float largest = 0;
    for (int64_t f = gaps[g].first; f <= gaps[g].second; ++f) {
      for (int c = 3; c < kColumns; ++c) {
        ASSERT_TRUE(std::isfinite(fitted.frame(f)[c])) << "frame " << f;
        largest = std::max(largest, std::fabs(fitted.frame(f)[c] - matched.frame(f)[c]));
      }
    }
    if (g == 0) {
      EXPECT_GT(largest, 0.05f) << "the first gap's window is fitted";
    } else {
      EXPECT_LE(largest, 1e-5f) << "gap " << g << " is beyond the bound: the matched fill";
    }
  }
  for (const auto& [gap_fill, keep_observed] : {std::pair<std::string, bool>{"spline", true}, {"matched", false}}) {
    v1::TakeHeader header = take_header(50);
    header.set_keep_observed(keep_observed);
    header.set_gap_fill(gap_fill);
    const StreamedTake refused = stream_take(*stub, true, header, chunks_of(head(gapped, 400)));
    EXPECT_EQ(refused.status.error_code(), StatusCode::INVALID_ARGUMENT) << gap_fill;
    EXPECT_EQ(refused.error_field, "gap_fill") << refused.status.error_message();
  }
}

// A CMU dance at 120 Hz through a small model trained on that rig (a job on
// three of the dances): a BVH of the same frame count at 120 Hz comes back.
TEST(TakesOfAnotherRig, ACmuDanceAt120HzComesBackAt120HzThroughAModelOfItsRig) {
  ScratchDir scratch;
  const fs::path root = scratch.path() / "data";
  for (const char* file : {"indian/04.bvh", "indian/06.bvh", "martial/03.bvh"}) {
    fs::create_directories((root / "dances" / file).parent_path());
    fs::copy_file(cmu_dance_dir() / file, root / "dances" / file);
  }
  // The job on one thread, as skeleton_service_test.cpp's: two spinning
  // beside another suite slow both many times over.
  ServerProcess server({"--state-dir", (scratch.path() / "state").string(), "--data-root", root.string(),
                        "--training-threads", "1"});
  const int port = server.rest_port();
  const auto started = Clock::now();
  const Reply job = post(port, "/v1/jobs",
                         json{{"dataset", "dances"}, {"variant", "DKGM"}, {"iterations", 3}, {"hidden", 16},
                              {"batch", 2}, {"seed", 1}, {"model_name", "dances"}});
  ASSERT_EQ(job.status, 200) << job.body;
  json record;
  for (int i = 0; i < 1500; ++i) {
    record = get(port, "/v1/jobs/" + job.document["id"].get<std::string>()).document;
    const std::string state = record.value("state", "");
    if (state == "succeeded" || state == "failed" || state == "cancelled") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_EQ(record.value("state", ""), "succeeded") << record.dump() << "\n" << server.log();
  std::printf("[ cmu      ] the rig's model trained in %.1f s\n", seconds_since(started));

  const fs::path dance = cmu_dance_dir() / "martial/04.bvh";
  std::ifstream in(dance, std::ios::binary);
  const std::string bvh((std::istreambuf_iterator<char>(in)), {});
  const BvhFile file = parse_bvh_text(bvh, dance.string());
  const auto take_started = Clock::now();
  const Reply reply = post_take(port, "/v1/takes:reconstruct?model=dances", bvh, "application/x-bvh", "application/x-bvh");
  ASSERT_EQ(reply.status, 200) << reply.body.substr(0, 500);
  const BvhFile out = parse_bvh_text(reply.body, "reply.bvh");
  std::printf("[ cmu      ] %s: %lld frames at %.0f Hz in %.2f s\n", dance.filename().c_str(),
              static_cast<long long>(file.frame_count()), 1 / file.frame_time_s, seconds_since(take_started));
  EXPECT_EQ(out.frame_count(), file.frame_count());
  // At the rate the file says: its 0.00833333 s is 120 Hz (bvh_frame_rate),
  // written back as 1/120 s.
  EXPECT_EQ(bvh_frame_rate(out), bvh_frame_rate(file));
  EXPECT_NEAR(out.frame_time_s, file.frame_time_s, 1e-6 * file.frame_time_s);
  EXPECT_EQ(out.joints.size(), file.joints.size());
  for (double v : out.values) ASSERT_TRUE(std::isfinite(v));

  // A file of the data root as the take (path=, an empty body): its own
  // frames and rate back; a path outside the root is refused naming it.
  const BvhFile trained_on = read_bvh_file((root / "dances/martial/03.bvh").string());
  const Reply from_path = post_take(port, "/v1/takes:reconstruct?model=dances&path=dances/martial/03.bvh", "",
                                    "text/plain", "application/x-bvh");
  ASSERT_EQ(from_path.status, 200) << from_path.body.substr(0, 500);
  EXPECT_EQ(parse_bvh_text(from_path.body, "reply.bvh").frame_count(), trained_on.frame_count());
  EXPECT_EQ(from_path.header("X-Take-Frame-Rate"), "120");
  const Reply outside = post_take(port, "/v1/takes:encode?model=dances&path=../escape.bvh", "", "text/plain",
                                  "application/json");
  EXPECT_EQ(outside.status, 400) << outside.body;
  if (outside.document.is_object()) EXPECT_EQ(outside.field(), "path") << outside.body;
}

// S5 files one after another until `minutes` of motion at 50 Hz, handed out
// in chunks as they are streamed (the test does not build the take either).
ChunkSource s5_minutes(double minutes) {
  struct Cursor {
    std::vector<const MotionFrames*> files;
    size_t file = 0;
    int64_t frame = 0, sent = 0, total = 0;
  };
  auto cursor = std::make_shared<Cursor>();
  for (const auto& [name, motion] : s5_files()) cursor->files.push_back(&motion);
  cursor->total = static_cast<int64_t>(minutes * 60 * 50) + 1;
  return [cursor](v1::FrameChunk* chunk) {
    if (cursor->sent >= cursor->total) return false;
    const MotionFrames& motion = *cursor->files[cursor->file];
    const int64_t count = std::min<int64_t>({kChunkFrames, motion.frame_count() - cursor->frame,
                                             cursor->total - cursor->sent});
    chunk->set_frames(static_cast<int32_t>(count));
    chunk->mutable_values()->Add(motion.frame(cursor->frame), motion.frame(cursor->frame) + count * kColumns);
    cursor->sent += count;
    cursor->frame += count;
    if (cursor->frame == motion.frame_count()) {
      cursor->frame = 0;
      cursor->file = (cursor->file + 1) % cursor->files.size();
    }
    return true;
  };
}

// Starts a new peak of the process's resident memory (VmHWM) from its
// present size: writing 5 to /proc/PID/clear_refs resets it.
void reset_peak(pid_t pid) {
  std::ofstream clear("/proc/" + std::to_string(pid) + "/clear_refs");
  clear << "5";
}

// A take of an hour costs the server what a take of ten minutes does: the
// rise of its peak resident memory over its size before the take (VmHWM
// reset), for a 60-minute take (180,001 frames at 50 Hz, the S5 files one
// after another, streamed in chunks) within 48 MiB of the rise for a
// 10-minute one. Holding the take whole would cost 59 MB more for the
// hour's input alone (150,000 frames x 99 floats), and as much again for
// its reply. A short take first brings the server to its working size (the
// first inference's buffers).
TEST(TakesOfAnHour, ASixtyMinuteTakeCostsTheServerNoMoreMemoryThanATenMinuteOne) {
  ServerProcess server({"--threads", "1"});
  auto stub = stub_of(server);
  v1::TakeHeader header = take_header(50);
  header.set_hop_seconds(6);
  ASSERT_TRUE(stream_take(*stub, false, header, s5_minutes(1), false).status.ok());
  struct Measured {
    StreamedTake take;
    long before_kib = 0, peak_kib = 0;
    double cpu_seconds = 0;
  };
  const auto measure = [&](double minutes) {
    Measured measured;
    reset_peak(server.pid());
    measured.before_kib = memory_of(server.pid()).rss_kib;
    const double cpu_before = cpu_seconds_of(server.pid());
    measured.take = stream_take(*stub, false, header, s5_minutes(minutes), false);
    measured.cpu_seconds = cpu_seconds_of(server.pid()) - cpu_before;
    measured.peak_kib = memory_of(server.pid()).peak_kib;
    std::printf("[ memory   ] a %2.0f-minute take: %.1f s wall, %.1f s server CPU; server RSS %ld MiB before, peak %ld "
                "MiB during (+%ld MiB)\n",
                minutes, measured.take.seconds, measured.cpu_seconds, measured.before_kib / 1024,
                measured.peak_kib / 1024, (measured.peak_kib - measured.before_kib) / 1024);
    return measured;
  };
  const Measured ten = measure(10);
  ASSERT_TRUE(ten.take.status.ok()) << ten.take.status.error_message();
  EXPECT_EQ(ten.take.frames, 30001);
  const Measured hour = measure(60);
  ASSERT_TRUE(hour.take.status.ok()) << hour.take.status.error_message();
  EXPECT_EQ(hour.take.frames, 180001);
  EXPECT_EQ(hour.take.summary.input_frames(), 180001);
  EXPECT_TRUE(hour.take.values_finite);
  EXPECT_LT(hour.peak_kib - hour.before_kib, ten.peak_kib - ten.before_kib + 48 * 1024);
}

// A server that runs one take at a time, for the refusals.
class BadTakes : public ::testing::Test {
 protected:
  // With a token: takes need none (the access of Encode), a data-root file
  // as the take does.
  static void SetUpTestSuite() {
    server_ = new ServerProcess({"--max-take-streams", "1", "--max-take-bytes", "1048576", "--auth-token", "secret"});
  }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static ServerProcess& server() { return *server_; }
  static ServerProcess* server_;

  // A good take of 6.5 s still goes through: the refused one gave its slot
  // back (a cancelled stream is noticed within a moment, so a few tries).
  static void expect_slot_free(const std::string& after) {
    auto stub = stub_of(server());
    const MotionFrames motion = head(s5("walking_1.txt"), 326);
    EncodedTake encoded;
    for (int attempt = 0; attempt < 50; ++attempt) {
      encoded = encode_take(*stub, take_messages(motion, 50));
      if (encoded.status.error_code() != StatusCode::RESOURCE_EXHAUSTED) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    EXPECT_TRUE(encoded.status.ok()) << "after " << after << ": " << encoded.status.error_message();
    EXPECT_EQ(encoded.track.frames(), 326) << after;
  }
};
ServerProcess* BadTakes::server_ = nullptr;

TEST_F(BadTakes, BadInputIsRefusedNamingTheFieldAndLeavesNothingBehind) {
  auto stub = stub_of(server());
  const MotionFrames& walking = s5("walking_1.txt");
  const MotionFrames ten_seconds = head(walking, 500);
  expect_slot_free("nothing");
  const Memory before = memory_of(server().pid());

  for (const double rate : {0.0, -50.0, std::numeric_limits<double>::quiet_NaN(), 5000.0}) {
    std::vector<v1::TakeInput> messages = take_messages(ten_seconds, rate);
    const EncodedTake encoded = encode_take(*stub, messages);
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "frame_rate",
                   "rate " + std::to_string(rate));
    EXPECT_NE(encoded.status.error_message().find("10 to 1000"), std::string::npos) << encoded.status.error_message();
  }
  expect_slot_free("bad rates");

  {  // A chunk claiming a billion frames carries 99 values.
    std::vector<v1::TakeInput> messages = {header_message(take_header(50)), chunk_message(walking.frame(0), 1)};
    messages.back().mutable_chunk()->set_frames(1000000000);
    const EncodedTake encoded = encode_take(*stub, messages);
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "chunk.values", "1e9 frames");
  }
  {  // The columns change between chunks.
    std::vector<v1::TakeInput> messages = {header_message(take_header(50)), chunk_message(walking.frame(0), 100),
                                           chunk_message(walking.frame(100), 100, 98)};
    const EncodedTake encoded = encode_take(*stub, messages);
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "chunk.values", "98 columns");
  }
  {  // The header's columns are not the model's.
    v1::TakeHeader header = take_header(50);
    header.set_columns(98);
    const EncodedTake encoded = encode_take(*stub, {header_message(header)});
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "columns", "header columns");
  }
  {  // NaN outside denoising.
    MotionFrames with_nan = ten_seconds;
    with_nan.values[200 * kColumns + 10] = std::numeric_limits<float>::quiet_NaN();
    const StreamedTake take = reconstruct(*stub, with_nan, 50);
    expect_refused(take.status, take.error_field, StatusCode::INVALID_ARGUMENT, "chunk.values", "NaN in reconstruct");
  }
  {  // A take of one frame, and one of 5 s: shorter than a window.
    for (const int64_t frames : {1, 250}) {
      const EncodedTake encoded = encode_take(*stub, take_messages(head(walking, frames), 50));
      expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "take",
                     std::to_string(frames) + " frames");
    }
  }
  {  // No header, two headers, no frames.
    EncodedTake encoded = encode_take(*stub, {chunk_message(walking.frame(0), 10)});
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "header", "no header");
    encoded = encode_take(*stub, {header_message(take_header(50)), header_message(take_header(50))});
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "header", "two headers");
    encoded = encode_take(*stub, {});
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "header", "empty stream");
    encoded = encode_take(*stub, {header_message(take_header(50))});
    expect_refused(encoded.status, encoded.error_field, StatusCode::INVALID_ARGUMENT, "take", "no frames");
  }
  expect_slot_free("bad chunks");

  {  // A stream cut midway: the client cancels after 20 s of a take.
    grpc::ClientContext context;
    auto stream = stub->ReconstructTake(&context);
    ASSERT_TRUE(stream->Write(header_message(take_header(50))));
    for (int64_t first = 0; first < 1000; first += 250) ASSERT_TRUE(stream->Write(chunk_message(walking.frame(first), 250)));
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    context.TryCancel();
    EXPECT_EQ(stream->Finish().error_code(), StatusCode::CANCELLED);
  }
  expect_slot_free("a cancelled stream");

  {  // More takes at once than --max-take-streams: the second is refused.
    grpc::ClientContext context;
    auto stream = stub->ReconstructTake(&context);
    ASSERT_TRUE(stream->Write(header_message(take_header(50))));
    ASSERT_TRUE(stream->Write(chunk_message(walking.frame(0), 100)));
    v1::TakeOutput first;
    ASSERT_TRUE(stream->Read(&first));  // the reply's header: the take holds its slot
    ASSERT_TRUE(first.has_header());
    const EncodedTake refused = encode_take(*stub, take_messages(ten_seconds, 50));
    EXPECT_EQ(refused.status.error_code(), StatusCode::RESOURCE_EXHAUSTED) << refused.status.error_message();
    EXPECT_NE(refused.status.error_message().find("--max-take-streams"), std::string::npos)
        << refused.status.error_message();
    const Reply rest = post_take(server().rest_port(), "/v1/takes:encode", motion_text(ten_seconds), "text/plain",
                                 "application/json");
    EXPECT_EQ(rest.status, 429) << rest.body;
    EXPECT_NE(rest.body.find("--max-take-streams"), std::string::npos) << rest.body;
    for (int64_t f = 100; f < 500; f += 100) ASSERT_TRUE(stream->Write(chunk_message(walking.frame(f), 100)));
    stream->WritesDone();
    v1::TakeOutput output;
    int64_t frames = 0;
    while (stream->Read(&output)) frames += output.has_chunk() ? output.chunk().frames() : 0;
    EXPECT_TRUE(stream->Finish().ok());
    EXPECT_EQ(frames, 500);
  }
  expect_slot_free("too many takes");

  // REST: the same refusals name the same fields.
  const int port = server().rest_port();
  const std::string text = motion_text(ten_seconds);
  for (const std::string rate : {"0", "-50", "nan"}) {
    const Reply reply = post_take(port, "/v1/takes:reconstruct?frame_rate=" + rate, text, "text/plain", "application/json");
    EXPECT_EQ(reply.status, 400) << reply.body;
    if (reply.document.is_object()) EXPECT_EQ(reply.field(), "frame_rate") << reply.body;
  }
  Reply reply = post_take(port, "/v1/takes:reconstruct", motion_text(head(walking, 1)), "text/plain", "application/json");
  EXPECT_EQ(reply.status, 400) << reply.body;
  if (reply.document.is_object()) EXPECT_EQ(reply.field(), "take") << reply.body;
  reply = post_take(port, "/v1/takes:reconstruct", "0.1,nan\n", "text/plain", "application/json");
  EXPECT_EQ(reply.status, 400) << reply.body;
  if (reply.document.is_object()) EXPECT_EQ(reply.field(), "body") << reply.body;
  reply = post_take(port, "/v1/takes:reconstruct?hop_seconds=7", text, "text/plain", "application/json");
  EXPECT_EQ(reply.status, 400) << reply.body;
  if (reply.document.is_object()) EXPECT_EQ(reply.field(), "hop_seconds") << reply.body;
  reply = post_take(port, "/v1/takes:reconstruct?speed=2", text, "text/plain", "application/json");
  EXPECT_EQ(reply.status, 400) << reply.body;
  if (reply.document.is_object()) EXPECT_EQ(reply.field(), "speed") << reply.body;
  // A body over --max-take-bytes is refused by its declared length.
  const std::string answer = raw_answer(port, "POST /v1/takes:reconstruct HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                             "Content-Type: text/plain\r\nContent-Length: 2000000\r\n\r\n");
  EXPECT_EQ(answer.rfind("HTTP/1.1 413", 0), 0u) << answer;
  EXPECT_NE(answer.find("--max-take-bytes"), std::string::npos) << answer;
  // path= needs the clip-read access (the token), then a data root.
  reply = post_take(port, "/v1/takes:reconstruct?path=S5/walking_1.txt", "", "text/plain", "application/json");
  EXPECT_EQ(reply.status, 401) << reply.body;
  reply = post(port, "/v1/takes:reconstruct?path=S5/walking_1.txt", "",
               {{"Accept", "application/json"}, {"Authorization", "Bearer secret"}}, "text/plain");
  EXPECT_EQ(reply.status, 409) << reply.body;
  if (reply.document.is_object()) EXPECT_EQ(reply.field(), "path") << reply.body;
  expect_slot_free("REST refusals");

  const Memory after = memory_of(server().pid());
  std::printf("[ memory   ] server RSS %ld MiB before the refusals, %ld MiB after\n", before.rss_kib / 1024,
              after.rss_kib / 1024);
  EXPECT_LT(after.rss_kib - before.rss_kib, 48 * 1024);
}

}  // namespace
}  // namespace mm::test
