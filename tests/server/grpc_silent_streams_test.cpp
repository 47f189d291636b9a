// Take streams that go silent, against a real server on loopback with a
// short --grpc-take-message-timeout-seconds: streams opened without their
// TakeHeader, or with it and then nothing, that hold every gRPC thread and
// every take slot are ended at the deadline with DEADLINE_EXCEEDED naming
// the option, after which another client's Sample and take are answered; a
// take that sends a chunk every second for longer than the deadline is
// answered whole; a take whose client does not read the reply is ended too.
// The server's threads are read from /proc/PID and printed before, while
// the streams are held and after.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "tests/common/joined_threads.h"
#include "tests/common/process_cost.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr int kColumns = 99;           // the shipped models' h36m-expmap-99
constexpr int kTimeoutSeconds = 3;     // --grpc-take-message-timeout-seconds here
const char* const kOption = "--grpc-take-message-timeout-seconds";

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// A stub on a connection of its own (a channel sharing no subchannel with
// any other), as separate clients have.
std::unique_ptr<v1::MotionManifold::Stub> stub_on_own_connection(const test::ServerProcess& server,
                                                                 bool bdp_probe = true) {
  grpc::ChannelArguments arguments;
  arguments.SetMaxReceiveMessageSize(-1);
  arguments.SetMaxSendMessageSize(-1);
  arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  // Without BDP probing the client's receive window stays at HTTP/2's
  // 64 KiB: a reply it does not read stalls the server's writes at once.
  if (!bdp_probe) arguments.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  return v1::MotionManifold::NewStub(
      grpc::CreateCustomChannel(server.grpc_target(), grpc::InsecureChannelCredentials(), arguments));
}

// Every call here gives up on its own after this: long past the server's
// deadline, so a server without one fails the test instead of hanging it.
void client_deadline(grpc::ClientContext& context, std::chrono::seconds seconds = 30s) {
  context.set_deadline(std::chrono::system_clock::now() + seconds);
}

v1::TakeInput header_message(double rate) {
  v1::TakeInput message;
  message.mutable_header()->set_frame_rate(rate);
  message.mutable_header()->set_columns(kColumns);
  return message;
}

// `frames` frames of the rest pose (every rotation zero) at the root.
v1::TakeInput chunk_message(int frames) {
  v1::TakeInput message;
  message.mutable_chunk()->set_frames(frames);
  message.mutable_chunk()->mutable_values()->Resize(frames * kColumns, 0.0f);
  return message;
}

std::string outcome(const grpc::Status& status) {
  return status.ok() ? "OK" : std::to_string(status.error_code()) + " " + status.error_message();
}

// What another client sees: a Sample and a 6 s EncodeTake (150 frames at
// 25 Hz), each on a connection of its own.
struct OtherClient {
  grpc::Status sample, take;
};
OtherClient other_client(const test::ServerProcess& server) {
  OtherClient seen;
  {
    auto stub = stub_on_own_connection(server);
    grpc::ClientContext context;
    client_deadline(context, 60s);
    v1::SampleRequest request;
    request.set_count(1);
    request.set_seed(3);
    v1::MotionsReply reply;
    seen.sample = stub->Sample(&context, request, &reply);
  }
  {
    auto stub = stub_on_own_connection(server);
    grpc::ClientContext context;
    client_deadline(context, 60s);
    v1::CodeTrack track;
    auto writer = stub->EncodeTake(&context, &track);
    if (writer->Write(header_message(25)) && writer->Write(chunk_message(150))) writer->WritesDone();
    seen.take = writer->Finish();
    if (seen.take.ok() && track.windows_size() == 0) seen.take = grpc::Status(grpc::StatusCode::INTERNAL, "no windows");
  }
  return seen;
}

std::vector<std::string> server_args() {
  // Few threads and one watch stream, so that a handful of silent streams
  // holds every thread: gRPC's quota is --grpc-threads plus
  // --max-watch-streams, its pollers included.
  return {"--grpc-threads", "6", "--grpc-max-streams-per-connection", "3", "--max-watch-streams", "1",
          "--max-watch-streams-per-client", "1", "--max-take-streams", "4", "--threads", "1",
          kOption, std::to_string(kTimeoutSeconds)};
}

// A take stream opened and left silent: EncodeTake or ReconstructTake,
// with its header or without; what it ended with, and when.
struct SilentStream {
  std::string rpc;
  bool sent_header = false;
  grpc::Status status;
  double ended_after = 0;  // seconds from its opening
};

// A first Sample with time to spare: loading the model is not what is
// measured.
void warm_up(const test::ServerProcess& server) {
  const OtherClient seen = other_client(server);
  ASSERT_TRUE(seen.sample.ok()) << outcome(seen.sample);
  ASSERT_TRUE(seen.take.ok()) << outcome(seen.take);
}

// 12 take streams on 4 connections (3 each, the per-connection cap), half
// EncodeTake and half ReconstructTake, a third of them with their header
// (taking the 4 take slots), the rest without: more than the server has
// threads (the surplus is refused by gRPC at once, "Server Threadpool
// Exhausted"). Another client is refused while they are held (printed: how
// many streams hold threads depends on gRPC's pollers). Every stream the
// server took ends at the deadline with DEADLINE_EXCEEDED naming the
// option, the server's threads return to what they were, and then another
// client's Sample and EncodeTake are answered. Before the deadline the
// streams were held until the client gave up: another client's Sample was
// refused with "Server Threadpool Exhausted" for as long.
// A ReconstructTake client reads its reply (the server writes the reply's
// header as soon as it has the take's header): gRPC hands a client the
// call's status only after the messages before it, so one that never reads
// would see its own deadline, not the server's, although the server ended
// the call and freed its thread at the deadline.
TEST(GrpcSilentStreams, StreamsWithoutTheirMessagesEndAtTheDeadlineAndOthersAreAnsweredAgain) {
  test::ServerProcess server(server_args());
  warm_up(server);
  const test::ProcessCost before = test::process_cost(server.pid());

  constexpr int kConnections = 4, kStreamsEach = 3;
  std::vector<std::unique_ptr<v1::MotionManifold::Stub>> stubs;
  for (int c = 0; c < kConnections; ++c) stubs.push_back(stub_on_own_connection(server));
  std::vector<SilentStream> streams(kConnections * kStreamsEach);
  {
    test::JoinedThreads threads;
    for (size_t i = 0; i < streams.size(); ++i) {
      SilentStream& stream = streams[i];
      stream.rpc = i % 2 == 0 ? "EncodeTake" : "ReconstructTake";
      stream.sent_header = i % 3 == 0;
      v1::MotionManifold::Stub& stub = *stubs[i % kConnections];
      threads.start([&stream, &stub] {
        grpc::ClientContext context;
        client_deadline(context);
        const auto opened = Clock::now();
        if (stream.rpc == "EncodeTake") {
          v1::CodeTrack track;
          auto writer = stub.EncodeTake(&context, &track);
          if (stream.sent_header) writer->Write(header_message(25));
          stream.status = writer->Finish();
        } else {
          auto call = stub.ReconstructTake(&context);
          if (stream.sent_header) call->Write(header_message(25));
          v1::TakeOutput reply;
          while (call->Read(&reply)) {
          }
          stream.status = call->Finish();
        }
        stream.ended_after = seconds_since(opened);
      });
    }
    std::this_thread::sleep_for(1s);  // every stream has reached the server
    const test::ProcessCost held = test::process_cost(server.pid());
    const OtherClient during = other_client(server);
    std::printf("[ held     ] server threads %d before, %d with %zu silent streams open; another client meanwhile: "
                "Sample %s, EncodeTake %s\n",
                before.threads, held.threads, streams.size(), outcome(during.sample).c_str(),
                outcome(during.take).c_str());
  }
  const auto ended = Clock::now();

  int refused_at_once = 0, cut = 0;
  std::map<std::string, int> outcomes;
  for (const SilentStream& stream : streams) {
    ++outcomes[stream.rpc + (stream.sent_header ? " with header: " : " without header: ") + outcome(stream.status) +
               (stream.status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED
                    ? " (after " + std::to_string(static_cast<int>(stream.ended_after)) + " s)"
                    : "")];
    if (stream.status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      ++refused_at_once;
      continue;
    }
    ++cut;
    EXPECT_EQ(stream.status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << outcome(stream.status);
    EXPECT_NE(stream.status.error_message().find(kOption), std::string::npos)
        << "the status does not name the option: " << outcome(stream.status);
    EXPECT_NE(stream.status.error_message().find(stream.sent_header ? "chunk" : "TakeHeader"), std::string::npos)
        << outcome(stream.status);
    // Not before the deadline (the watchdog's clock and this one differ by
    // the stream's opening, well under a second).
    EXPECT_GE(stream.ended_after, kTimeoutSeconds - 1.0) << outcome(stream.status);
  }
  for (const auto& [text, count] : outcomes) std::printf("[ streams  ] %2d x %s\n", count, text.c_str());
  EXPECT_GE(cut, 4) << "fewer silent streams than expected reached a thread";

  std::this_thread::sleep_for(500ms);
  const test::ProcessCost after = test::process_cost(server.pid());
  const auto probe_started = Clock::now();
  const OtherClient afterwards = other_client(server);
  std::printf("[ after    ] %d streams cut, %d refused at once; server threads %d; another client %.1f s after "
              "they ended: Sample %s, EncodeTake %s (%.2f s)\n",
              cut, refused_at_once, after.threads, seconds_since(ended), outcome(afterwards.sample).c_str(),
              outcome(afterwards.take).c_str(), seconds_since(probe_started));
  EXPECT_TRUE(afterwards.sample.ok()) << outcome(afterwards.sample);
  EXPECT_TRUE(afterwards.take.ok()) << outcome(afterwards.take);
  EXPECT_LE(after.threads, before.threads + 4) << "the silent streams' threads stayed";
}

// A ReconstructTake of 8 s at 25 Hz sent one second at a time, one chunk a
// second, its reply read as it comes: 8 s in all, more than twice the
// deadline, but never a gap of more than a second, so it is answered whole.
TEST(GrpcSilentStreams, SlowSteadyTakeIsNotCut) {
  test::ServerProcess server(server_args());
  warm_up(server);
  auto stub = stub_on_own_connection(server);
  grpc::ClientContext context;
  client_deadline(context, 120s);
  const auto started = Clock::now();
  auto call = stub->ReconstructTake(&context);
  constexpr int kSeconds = 8, kRate = 25;
  std::thread writer([&] {
    if (!call->Write(header_message(kRate))) return;
    for (int second = 0; second < kSeconds; ++second) {
      std::this_thread::sleep_for(1s);
      if (!call->Write(chunk_message(kRate))) return;
    }
    call->WritesDone();
  });
  int64_t frames = 0;
  bool summary = false;
  v1::TakeOutput output;
  while (call->Read(&output)) {
    if (output.has_chunk()) frames += output.chunk().frames();
    if (output.has_summary()) summary = true;
  }
  writer.join();
  const grpc::Status status = call->Finish();
  std::printf("[ steady   ] %d s at %d Hz, a chunk a second: %s, %lld frames back, in %.1f s (deadline %d s)\n",
              kSeconds, kRate, outcome(status).c_str(), static_cast<long long>(frames), seconds_since(started),
              kTimeoutSeconds);
  ASSERT_TRUE(status.ok()) << outcome(status);
  EXPECT_EQ(frames, kSeconds * kRate);
  EXPECT_TRUE(summary);
}

// A ReconstructTake of 60 s at 1000 Hz (24 MB of reply) from a client that
// sends it whole and then reads nothing for three deadlines: the server's
// reply writes wait on the client's flow-control window, and are given up
// at the deadline, naming the option, instead of holding the thread and the
// take slot until the client reads (before: for ever, or here until the
// client drained the whole reply, and then OK).
TEST(GrpcSilentStreams, ReplyNotReadEndsAtTheDeadline) {
  test::ServerProcess server(server_args());
  warm_up(server);
  auto stub = stub_on_own_connection(server, /*bdp_probe=*/false);
  grpc::ClientContext context;
  client_deadline(context, 120s);
  const auto started = Clock::now();
  auto call = stub->ReconstructTake(&context);
  constexpr int kRate = 1000, kSeconds = 60;
  bool sent_whole = false;
  std::thread writer([&] {
    bool ok = call->Write(header_message(kRate));
    for (int second = 0; ok && second < kSeconds; ++second) ok = call->Write(chunk_message(kRate));
    if (ok) call->WritesDone();
    sent_whole = ok;
  });
  std::this_thread::sleep_for(std::chrono::seconds(3 * kTimeoutSeconds));
  int64_t frames = 0;
  v1::TakeOutput output;
  while (call->Read(&output)) frames += output.has_chunk() ? output.chunk().frames() : 0;
  writer.join();
  const grpc::Status status = call->Finish();
  std::printf("[ unread   ] sent %s, %lld of %d frames read back, %s after %.1f s (deadline %d s)\n",
              sent_whole ? "whole" : "in part", static_cast<long long>(frames), kRate * kSeconds,
              outcome(status).c_str(), seconds_since(started), kTimeoutSeconds);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << outcome(status);
  EXPECT_NE(status.error_message().find(kOption), std::string::npos) << outcome(status);
  EXPECT_NE(status.error_message().find("reply"), std::string::npos) << outcome(status);
  EXPECT_LT(frames, kRate * kSeconds);
  // The take slot is free again: another client's take is answered.
  const OtherClient afterwards = other_client(server);
  EXPECT_TRUE(afterwards.take.ok()) << outcome(afterwards.take);
}

}  // namespace
}  // namespace mm
