// Hostile traffic on the gRPC port of a real server on loopback, a token
// configured: one connection opening far more calls than its stream cap, a
// compression bomb, a rapid-reset burst (streams opened and reset at once,
// written as raw HTTP/2 frames so that no client library's manners soften
// it), and connections kept idle, pinged or held past their age. Another
// client's gRPC Sample and REST /healthz are answered within 5 s through
// the flood and the bomb, and once a burst has been digested. The server's
// CPU time, peak memory and threads are read from /proc/PID and printed;
// peak memory, served calls, threads and the 5 s answers are asserted.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <httplib.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "tests/common/process_cost.h"
#include "tests/server/grpc_calls.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using namespace std::chrono_literals;

const char* const kToken = "grpc-hostile-traffic-token-51c2";

std::vector<std::string> server_args(std::vector<std::string> more = {}) {
  std::vector<std::string> args = {"--auth-token", kToken};
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

using test::ProcessCost;
using test::process_cost;

// Waits until the server has stopped spending CPU (no more than 20 ms in
// 300 ms) or 20 s have passed; returns its cost then: the cost of a burst
// includes what the server does after the last byte of it arrived.
ProcessCost cost_once_quiet(pid_t pid) {
  ProcessCost last = process_cost(pid);
  const auto give_up = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < give_up) {
    std::this_thread::sleep_for(300ms);
    const ProcessCost now = process_cost(pid);
    if (now.cpu_seconds - last.cpu_seconds <= 0.02) return now;
    last = now;
  }
  return last;
}

v1::SampleRequest one_sample(uint64_t seed) {
  v1::SampleRequest request;
  request.set_count(1);
  request.set_seed(seed);
  return request;
}

// A first Sample with time to spare: the first inference after the start
// loads what the model needs, which is not what the 5 s bounds measure.
void warm_up(const test::ServerProcess& server) {
  auto stub = test::grpc_stub(server.grpc_target());
  auto context = test::grpc_context();
  v1::MotionsReply reply;
  const auto status = stub->Sample(context.get(), one_sample(1), &reply);
  ASSERT_TRUE(status.ok()) << status.error_message();
}

// What another client sees: a gRPC Sample on a channel of its own and a
// REST /healthz, each given 5 s (the deadline and the socket timeouts: with
// 2 s, a Sample of the default model missed it beside other tests under
// ctest -j2, flood or no flood). An empty string when both were answered,
// else what went wrong.
std::string other_client_problem(const test::ServerProcess& server) {
  std::string problem;
  {
    auto stub = test::grpc_stub(server.grpc_target());
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + 5s);
    v1::MotionsReply reply;
    const auto status = stub->Sample(&context, one_sample(7), &reply);
    if (!status.ok()) {
      problem += "gRPC Sample: " + std::to_string(status.error_code()) + " " + status.error_message() + "; ";
    }
  }
  httplib::Client client("127.0.0.1", server.rest_port());
  client.set_connection_timeout(5);
  client.set_read_timeout(5);
  client.set_write_timeout(5);
  const auto result = client.Get("/healthz");
  if (!result || result->status != 200) {
    problem += "REST /healthz: " + (result ? std::to_string(result->status) : httplib::to_string(result.error()));
  }
  return problem;
}

// gRPC Samples the core has served, whatever their outcome: the sum of
// mm_requests_total over the codes, read from REST /metrics.
long grpc_samples_served(const test::ServerProcess& server) {
  httplib::Client client("127.0.0.1", server.rest_port());
  client.set_read_timeout(30);
  const auto result = client.Get("/metrics");
  if (!result || result->status != 200) return -1;
  long total = 0;
  std::istringstream lines(result->body);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("mm_requests_total{", 0) == 0 && line.find("operation=\"sample\"") != std::string::npos &&
        line.find("protocol=\"grpc\"") != std::string::npos) {
      total += std::stol(line.substr(line.rfind(' ') + 1));
    }
  }
  return total;
}

// ---------------------------------------------------------------------------
// A raw HTTP/2 client: the connection preface, SETTINGS, and streams written
// frame by frame (HPACK literals without indexing, no Huffman coding), with a
// reader that acknowledges the server's SETTINGS and PINGs and counts what
// it sends back. Enough to open and reset streams faster than any gRPC
// client library would.
class RawHttp2Connection {
 public:
  // `answer_pings` false: the server's PINGs go unanswered, as from a peer
  // that vanished without closing its connection.
  explicit RawHttp2Connection(int port, bool answer_pings = true) : port_(port), answer_pings_(answer_pings) {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_port = htons(static_cast<uint16_t>(port));
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (fd_ < 0 || connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("cannot connect to 127.0.0.1:" + std::to_string(port));
    }
    const int one = 1;
    setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::string preface = "PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";
    preface += frame(0x4, 0, 0, "");  // SETTINGS, the defaults
    write_all(preface);
    reader_ = std::thread([this] { read_frames(); });
  }
  ~RawHttp2Connection() {
    ::shutdown(fd_, SHUT_RDWR);
    reader_.join();
    close(fd_);
  }

  // HEADERS opening a unary call of `method`, DATA with `message` (one gRPC
  // message, uncompressed) ending the stream, and RST_STREAM (CANCEL): a
  // whole request, withdrawn at once.
  std::string opened_and_reset(uint32_t stream, const std::string& method, const std::string& message) const {
    std::string headers;
    for (const auto& [name, value] : std::vector<std::pair<std::string, std::string>>{
             {":method", "POST"},
             {":scheme", "http"},
             {":path", method},
             {":authority", "127.0.0.1:" + std::to_string(port_)},
             {"content-type", "application/grpc"},
             {"te", "trailers"}}) {
      headers += '\0';  // literal header field without indexing, new name
      headers += hpack_string(name);
      headers += hpack_string(value);
    }
    std::string data(5, '\0');
    for (int i = 0; i < 4; ++i) data[1 + i] = static_cast<char>((message.size() >> (24 - 8 * i)) & 0xff);
    data += message;
    return frame(0x1, 0x4, stream, headers) + frame(0x0, 0x1, stream, data) +
           frame(0x3, 0, stream, std::string("\0\0\0\x08", 4));
  }

  void write_all(const std::string& bytes) {
    size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) return;  // the server closed the connection: counted by the reader
      sent += static_cast<size_t>(n);
    }
  }

  int goaways() const { return goaways_; }
  int pings_received() const { return pings_received_; }
  // Waits for the server to close the connection for at most `timeout`.
  bool await_closed(std::chrono::milliseconds timeout) const {
    const auto give_up = std::chrono::steady_clock::now() + timeout;
    while (!closed_ && std::chrono::steady_clock::now() < give_up) std::this_thread::sleep_for(20ms);
    return closed_;
  }
  // The last GOAWAY's error code and debug data ("" before one came).
  std::string goaway() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return goaways_ == 0 ? "" : std::to_string(goaway_code_) + " " + goaway_debug_;
  }
  // Waits for a GOAWAY for at most `timeout`; returns goaway().
  std::string await_goaway(std::chrono::milliseconds timeout) const {
    const auto give_up = std::chrono::steady_clock::now() + timeout;
    while (goaways_ == 0 && std::chrono::steady_clock::now() < give_up) std::this_thread::sleep_for(20ms);
    return goaway();
  }
  // A PING with 8 bytes of payload.
  static std::string ping() { return frame(0x6, 0, 0, std::string(8, 'p')); }
  // HEADERS opening a stream of `method` that sends nothing more.
  std::string opened(uint32_t stream, const std::string& method) const {
    const std::string whole = opened_and_reset(stream, method, "");
    const size_t headers_length = 9 + ((static_cast<uint8_t>(whole[1]) << 8) | static_cast<uint8_t>(whole[2]));
    return whole.substr(0, headers_length);
  }
  int resets_received() const { return resets_; }

 private:
  static std::string frame(uint8_t type, uint8_t flags, uint32_t stream, const std::string& payload) {
    std::string bytes;
    bytes += static_cast<char>((payload.size() >> 16) & 0xff);
    bytes += static_cast<char>((payload.size() >> 8) & 0xff);
    bytes += static_cast<char>(payload.size() & 0xff);
    bytes += static_cast<char>(type);
    bytes += static_cast<char>(flags);
    for (int i = 0; i < 4; ++i) bytes += static_cast<char>((stream >> (24 - 8 * i)) & 0xff);
    return bytes + payload;
  }
  // An HPACK string literal: the length as a 7-bit-prefix integer, no
  // Huffman coding.
  static std::string hpack_string(const std::string& text) {
    std::string bytes;
    size_t length = text.size();
    if (length < 127) {
      bytes += static_cast<char>(length);
    } else {
      bytes += static_cast<char>(127);
      length -= 127;
      while (length >= 128) {
        bytes += static_cast<char>((length & 0x7f) | 0x80);
        length >>= 7;
      }
      bytes += static_cast<char>(length);
    }
    return bytes + text;
  }

  void read_frames() {
    std::string buffer;
    char chunk[65536];
    for (;;) {
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) {
        closed_ = true;
        return;
      }
      buffer.append(chunk, static_cast<size_t>(n));
      while (buffer.size() >= 9) {
        const size_t length = (static_cast<uint8_t>(buffer[0]) << 16) | (static_cast<uint8_t>(buffer[1]) << 8) |
                              static_cast<uint8_t>(buffer[2]);
        if (buffer.size() < 9 + length) break;
        const uint8_t type = static_cast<uint8_t>(buffer[3]);
        const uint8_t flags = static_cast<uint8_t>(buffer[4]);
        if (type == 0x4 && (flags & 0x1) == 0) write_all(frame(0x4, 0x1, 0, ""));           // SETTINGS: ACK
        if (type == 0x6 && (flags & 0x1) == 0) {
          ++pings_received_;
          if (answer_pings_) write_all(frame(0x6, 0x1, 0, buffer.substr(9, length)));  // PING: ACK
        }
        if (type == 0x3) ++resets_;
        if (type == 0x7 && length >= 8) {
          std::lock_guard<std::mutex> lock(mutex_);
          const std::string payload = buffer.substr(9, length);
          goaway_code_ = (static_cast<uint8_t>(payload[4]) << 24) | (static_cast<uint8_t>(payload[5]) << 16) |
                         (static_cast<uint8_t>(payload[6]) << 8) | static_cast<uint8_t>(payload[7]);
          goaway_debug_ = payload.substr(8);
          ++goaways_;
        }
        buffer.erase(0, 9 + length);
      }
    }
  }

  int port_;
  bool answer_pings_;
  int fd_ = -1;
  std::atomic<bool> closed_{false};
  std::atomic<int> pings_received_{0};
  std::thread reader_;
  std::atomic<int> goaways_{0}, resets_{0};
  mutable std::mutex mutex_;
  uint32_t goaway_code_ = 0;
  std::string goaway_debug_;
};

// ---------------------------------------------------------------------------

// 1,000 calls at once on one channel, each an EncodeTake stream that never
// sends its header: a call that holds a server thread for as long as its
// client likes (a Sample holds one for an inference, and on today's server
// 874 of 1,000 Samples on one channel were refused with "Server Threadpool
// Exhausted" while another client's calls were refused too). The
// connection's stream cap keeps all but 24 of them (16 calls and the 8
// watch streams a client may hold) in the client's own queue, so they never
// reach the server's threads, and another client's Sample and /healthz are
// answered meanwhile.
TEST(GrpcHostileTraffic, OneChannelWithThousandCallsLeavesOtherClientsAnswered) {
  test::ServerProcess server(server_args());
  warm_up(server);

  auto channel = grpc::CreateChannel(server.grpc_target(), grpc::InsecureChannelCredentials());
  // Connected first, so that the server's SETTINGS (its stream cap) are
  // known before the first call is written.
  ASSERT_TRUE(channel->WaitForConnected(std::chrono::system_clock::now() + 10s));
  auto stub = v1::MotionManifold::NewStub(channel);
  constexpr int kCalls = 1000;
  struct Call {
    grpc::ClientContext context;
    v1::CodeTrack reply;
    grpc::Status status;
    std::unique_ptr<grpc::ClientAsyncWriter<v1::TakeInput>> writer;
  };
  grpc::CompletionQueue queue;
  std::vector<std::unique_ptr<Call>> calls;
  for (int i = 0; i < kCalls; ++i) {
    auto call = std::make_unique<Call>();
    call->context.set_deadline(std::chrono::system_clock::now() + 60s);
    call->writer = stub->PrepareAsyncEncodeTake(&call->context, &call->reply, &queue);
    call->writer->StartCall(nullptr);
    call->writer->Finish(&call->status, call.get());
    calls.push_back(std::move(call));
  }
  std::this_thread::sleep_for(1s);  // the calls the connection lets through have reached the server
  const std::string problem = other_client_problem(server);
  EXPECT_EQ(problem, "") << "another client while one channel held " << kCalls << " calls";

  // The queued calls first: cancelling a call on the server frees its
  // stream for the next queued one, which would open only to be reset.
  for (auto call = calls.rbegin(); call != calls.rend(); ++call) (*call)->context.TryCancel();
  for (int event = 0; event < 2 * kCalls; ++event) {
    void* tag = nullptr;
    bool ok = false;
    ASSERT_TRUE(queue.Next(&tag, &ok));
  }
  std::map<std::string, int> outcomes;
  for (const auto& call : calls) {
    const auto& status = call->status;
    ++outcomes[status.ok() ? "OK" : std::to_string(status.error_code()) + " " + status.error_message()];
  }
  for (const auto& [outcome, count] : outcomes) std::printf("[ flood    ] %4d x %s\n", count, outcome.c_str());
  for (const auto& call : calls) {
    ASSERT_NE(call->status.error_message(), "Server Threadpool Exhausted")
        << "one connection took every thread of the server";
  }
}

// A Decode of 256 MiB of zeros, gzip-compressed by the client (about 256 kB
// on the wire), to a server that takes no compressed requests: refused from
// its headers, naming compression, before it is inflated, so that the
// server's peak memory grows by less than 64 MiB. (The 1 GiB bomb measured
// for the README is the same request four times larger; building and
// compressing it takes the client longer than this test should.) Today's
// server inflated it whole before refusing it for its size: +273 MiB peak
// and 1.7 s of CPU.
TEST(GrpcHostileTraffic, CompressedRequestIsRefusedBeforeItIsInflated) {
  test::ServerProcess server(server_args());
  const ProcessCost before = process_cost(server.pid());

  v1::DecodeRequest bomb;
  bomb.add_codes()->mutable_values()->Resize(64 << 20, 0.0f);
  auto stub = test::grpc_stub(server.grpc_target());
  auto context = test::grpc_context();
  context->set_compression_algorithm(GRPC_COMPRESS_GZIP);
  v1::MotionsReply reply;
  const auto status = stub->Decode(context.get(), bomb, &reply);
  bomb.Clear();

  const ProcessCost after = cost_once_quiet(server.pid());
  std::printf("[ bomb     ] %d %s; server peak RSS %+ld KiB, CPU %.0f ms, RSS after %ld MiB\n", status.error_code(),
              status.error_message().c_str(), after.peak_rss_kib - before.peak_rss_kib,
              1000 * (after.cpu_seconds - before.cpu_seconds), after.rss_kib / 1024);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNIMPLEMENTED) << status.error_message();
  EXPECT_NE(status.error_message().find("ompression algorithm 'gzip' is disabled"), std::string::npos)
      << status.error_message();
  EXPECT_LT(after.peak_rss_kib - before.peak_rss_kib, 64 * 1024) << "the request was inflated";
  EXPECT_LT(after.cpu_seconds - before.cpu_seconds, 0.1) << "the request was inflated";
  EXPECT_EQ(other_client_problem(server), "");
  // The refusal is gRPC's own (the sync API never sees the call); the log
  // names the option that would take such requests.
  EXPECT_NE(server.log().find("--grpc-accept-compression"), std::string::npos) << server.log();
}

// With --grpc-accept-compression a compressed request is taken: the option
// is what turns compression on, and nothing else refuses it.
TEST(GrpcHostileTraffic, AcceptCompressionOptionTakesCompressedRequests) {
  test::ServerProcess server(server_args({"--grpc-accept-compression"}));
  auto stub = test::grpc_stub(server.grpc_target());
  auto context = test::grpc_context();
  context->set_compression_algorithm(GRPC_COMPRESS_GZIP);
  v1::MotionsReply reply;
  const auto status = stub->Sample(context.get(), one_sample(3), &reply);
  EXPECT_TRUE(status.ok()) << status.error_code() << " " << status.error_message();
  EXPECT_EQ(reply.motions_size(), 1);
}

int lines_containing(const std::string& text, const std::string& part) {
  std::istringstream lines(text);
  int count = 0;
  for (std::string line; std::getline(lines, line);) count += line.find(part) != std::string::npos;
  return count;
}

// 300 compressed Samples refused in a row: gRPC logs its refusal of each
// ("Compression algorithm 'gzip' is disabled.", before the service sees the
// call), so a client looping on them filled the log, a line a call (today's
// server: 300 lines). The server keeps the first refusal of each minute,
// naming the option, and counts the rest, whose number it logs with the
// next minute's first or at shutdown.
TEST(GrpcHostileTraffic, RefusedCompressedRequestsAreLoggedOnceAMinute) {
  test::ServerProcess server(server_args());
  constexpr int kCalls = 300;
  auto stub = test::grpc_stub(server.grpc_target());
  int refused = 0;
  const auto started = std::chrono::steady_clock::now();
  for (int i = 0; i < kCalls; ++i) {
    auto context = test::grpc_context();
    context->set_compression_algorithm(GRPC_COMPRESS_GZIP);
    v1::MotionsReply reply;
    refused += stub->Sample(context.get(), one_sample(i), &reply).error_code() == grpc::StatusCode::UNIMPLEMENTED;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const std::string while_serving = server.log();
  EXPECT_EQ(server.terminate(), 0) << server.log();
  const std::string log = server.log();
  const int refusal_lines = lines_containing(while_serving, "is disabled");
  std::printf("[ refusals ] %d of %d compressed Samples refused in %.1f s; log lines naming the refusal while "
              "serving: %d; after shutdown: %d\n",
              refused, kCalls, seconds, refusal_lines, lines_containing(log, "compressed request"));
  ASSERT_EQ(refused, kCalls);
  // Well within a minute, even on a loaded machine: one line. (Should the
  // loop ever take over a minute, a second line is the right behaviour.)
  if (seconds < 55) EXPECT_EQ(refusal_lines, 1) << while_serving;
  EXPECT_NE(while_serving.find("gRPC refused a compressed request: Compression algorithm 'gzip' is disabled. "
                               "(--grpc-accept-compression takes them"),
            std::string::npos)
      << while_serving;
  if (seconds < 55) {
    EXPECT_NE(log.find("gRPC refused " + std::to_string(kCalls - 1) + " more compressed requests"), std::string::npos)
        << log;
  }
}

// 5,000 Sample streams opened and reset in one write on one connection
// ("rapid reset", CVE-2023-44487). Neither the per-connection stream cap
// (each stream is closed before the next opens) nor anything else in gRPC
// 1.51 limits resets, and its synchronous server refuses calls ("Server
// Threadpool Exhausted") while every thread is busy with the burst: the
// ordinary calls of other clients during it are printed, refused or not
// (README, "Security"). What is asserted is what holds: the withdrawn calls
// cost no inference, the burst's threads stay within the quota, and once
// the server has digested the burst another client's Sample and /healthz
// are answered within 5 s. The CPU per reset stream is printed.
TEST(GrpcHostileTraffic, RapidResetBurstCostsNoInferenceAndServerRecovers) {
  test::ServerProcess server(server_args());
  warm_up(server);
  constexpr int kStreams = 5000;  // 25 kB of DATA: within HTTP/2's initial connection window
  std::string message;
  one_sample(1).SerializeToString(&message);

  RawHttp2Connection attacker(server.grpc_port());
  std::string burst;
  for (int i = 0; i < kStreams; ++i) {
    burst += attacker.opened_and_reset(static_cast<uint32_t>(2 * i + 1), "/motionmanifold.v1.MotionManifold/Sample",
                                       message);
  }
  std::this_thread::sleep_for(200ms);  // the SETTINGS exchanged
  const ProcessCost before = cost_once_quiet(server.pid());
  const long served_before = grpc_samples_served(server);

  // Ordinary calls on channels of their own while the burst is served.
  std::atomic<bool> burst_written{false};
  std::vector<std::string> refused;
  std::mutex refused_mutex;
  std::atomic<int> ordinary{0};
  std::vector<std::thread> clients;
  for (int c = 0; c < 4; ++c) {
    clients.emplace_back([&] {
      auto stub = test::grpc_stub(server.grpc_target());
      for (int i = 0; i < 10; ++i) {
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + 30s);
        // A call without inference, so that the CPU measured is the burst's.
        v1::ListModelsReply reply;
        const auto status = stub->ListModels(&context, v1::ListModelsRequest(), &reply);
        ++ordinary;
        if (!status.ok()) {
          std::lock_guard<std::mutex> lock(refused_mutex);
          refused.push_back(std::to_string(status.error_code()) + " " + status.error_message());
        }
        if (burst_written && i >= 4) return;
      }
    });
  }
  std::atomic<bool> sampling{true};
  std::atomic<int> peak_threads{before.threads};
  std::thread sampler([&] {
    while (sampling) {
      peak_threads = std::max(peak_threads.load(), process_cost(server.pid()).threads);
      std::this_thread::sleep_for(5ms);
    }
  });
  const auto started = std::chrono::steady_clock::now();
  attacker.write_all(burst);
  const double write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  burst_written = true;
  for (auto& client : clients) client.join();
  const ProcessCost after = cost_once_quiet(server.pid());
  sampling = false;
  sampler.join();
  const long burst_served = grpc_samples_served(server) - served_before;
  const std::string problem = other_client_problem(server);

  std::printf("[ reset    ] %d streams written in %.3f s; server CPU %.2f s (%.0f us a stream, %d ordinary calls "
              "included), threads %d -> at most %d -> %d, GOAWAY %d, RST_STREAM from the server %d\n",
              kStreams, write_seconds, after.cpu_seconds - before.cpu_seconds,
              1e6 * (after.cpu_seconds - before.cpu_seconds) / kStreams, ordinary.load(), before.threads,
              peak_threads.load(), after.threads, attacker.goaways(), attacker.resets_received());
  std::printf("[ reset    ] Samples of the burst served by the core: %ld of %d\n", burst_served, kStreams);
  EXPECT_EQ(problem, "") << "another client once the burst was digested";
  // A stream reset after its request arrived may be served before the
  // reset is read; the rest must cost no inference.
  EXPECT_LT(burst_served, kStreams / 100) << "withdrawn calls were served";
  // gRPC's thread quota (--grpc-threads plus --max-watch-streams, 128) bounds
  // the threads a burst makes the server start.
  EXPECT_LE(peak_threads.load(), before.threads + 128) << "the burst's threads outgrew the quota";
  EXPECT_LE(after.threads, before.threads + 4) << "the burst's threads stayed";
  std::printf("[ reset    ] ordinary calls during the burst: %zu of %d refused%s%s\n", refused.size(),
              ordinary.load(), refused.empty() ? "" : ", the first: ", refused.empty() ? "" : refused.front().c_str());
}

// The connection limits, each seen as the GOAWAY it sends on a raw HTTP/2
// connection: a connection without calls closed once idle ("max_idle"), a
// client pinging without calls sent ENHANCE_YOUR_CALM ("too_many_pings")
// at its third ping, and a connection holding a stream closed once too old
// ("max_age"), its stream cut off after the grace. Short limits, so that
// the test need not wait the defaults' minutes.
TEST(GrpcHostileTraffic, ConnectionLimitsSendGoaway) {
  test::ServerProcess server(server_args({"--grpc-max-connection-idle-seconds", "2", "--grpc-max-connection-age-seconds",
                                          "4", "--grpc-max-connection-age-grace-seconds", "1"}));
  RawHttp2Connection idle(server.grpc_port());
  RawHttp2Connection pinging(server.grpc_port());
  RawHttp2Connection busy(server.grpc_port());
  busy.write_all(busy.opened(1, "/motionmanifold.v1.MotionManifold/EncodeTake"));
  for (int i = 0; i < 5; ++i) pinging.write_all(RawHttp2Connection::ping());

  EXPECT_EQ(pinging.await_goaway(5s), "11 too_many_pings") << "pings without calls are not limited";
  // gRPC 1.51 says "2 enter idle" (its error code for the idle close).
  EXPECT_NE(idle.await_goaway(10s).find("idle"), std::string::npos) << "an idle connection is kept";
  EXPECT_EQ(busy.goaways(), 0) << "a connection with a stream open is not idle: " << busy.goaway();
  // The age's GOAWAY is NO_ERROR without debug data.
  EXPECT_EQ(busy.await_goaway(10s), "0 ") << "an old connection is kept";
}

// The server's keepalive: a peer that stops answering pings (gone without
// a FIN) loses its connection, and with it the streams it held; a peer that
// answers keeps it. Short limits, so that the test need not wait a minute.
TEST(GrpcHostileTraffic, PeerThatStopsAnsweringPingsIsDisconnected) {
  test::ServerProcess server(server_args({"--grpc-keepalive-seconds", "1", "--grpc-keepalive-timeout-seconds", "1"}));
  RawHttp2Connection silent(server.grpc_port(), /*answer_pings=*/false);
  RawHttp2Connection answering(server.grpc_port());
  // Each holds a stream, as a client in the middle of a take would.
  silent.write_all(silent.opened(1, "/motionmanifold.v1.MotionManifold/EncodeTake"));
  answering.write_all(answering.opened(1, "/motionmanifold.v1.MotionManifold/EncodeTake"));
  EXPECT_TRUE(silent.await_closed(10s)) << "a peer that answers no ping keeps its connection";
  EXPECT_GE(silent.pings_received(), 1);
  EXPECT_FALSE(answering.await_closed(1s)) << "a peer that answers was disconnected";
  EXPECT_GE(answering.pings_received(), 1);
}

// A stream cap that would let one connection take every thread is refused
// at start, naming both options.
TEST(GrpcHostileTraffic, StreamCapNotBelowThreadsIsRefusedAtStart) {
  try {
    test::ServerProcess server(server_args({"--grpc-threads", "16", "--grpc-max-streams-per-connection", "16"}));
    ADD_FAILURE() << "the server started with as many streams a connection as threads";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what())
                  .find("--grpc-max-streams-per-connection (16) must be fewer than --grpc-threads (16)"),
              std::string::npos)
        << error.what();
  }
}

}  // namespace
}  // namespace mm
