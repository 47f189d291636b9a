// Job watch streams cannot starve calls: the real server with 200 REST event
// streams or 200 gRPC WatchJob streams asked for at once keeps at most
// --max-watch-streams of them (64) open, from one client address at most
// --max-watch-streams-per-client (8), refuses the rest at once with 429 /
// RESOURCE_EXHAUSTED naming the cap, and meanwhile answers health, models
// and inference calls; the caps' own bookkeeping (core/watch_streams.h)
// first. The streams watch a queued job that does not change (another job
// trains, at the lowest CPU priority, ahead of it).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <httplib.h>

#include <chrono>
#include <iostream>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "probes/health_probe.grpc.pb.h"
#include "server/api/api_types.h"
#include "server/core/watch_streams.h"
#include "tests/common/test_environment.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace v1 = ::motionmanifold::v1;
using json = nlohmann::json;
using service::ApiError;
using service::ErrorCode;
using service::WatchStreams;
using test::ServerProcess;

// How long one answer may take before the test counts it as not answered:
// far more than a call takes on a busy machine, far less than a starved
// server keeps a client waiting (for ever). Not a speed claim. Inference
// competes for the CPU with whatever else the machine runs (a Sample took up
// to 10 s on 2 cores shared with compilers and the test's training job), so
// it gets more.
constexpr auto kPatience = std::chrono::seconds(10);
constexpr auto kInferencePatience = std::chrono::seconds(60);
constexpr int kAskedStreams = 200;
constexpr int kDefaultCap = 64;           // --max-watch-streams
constexpr int kDefaultPerClientCap = 8;   // --max-watch-streams-per-client

// ------------------------------------------------------------ the caps alone

TEST(WatchStreamCaps, RefuseBeyondTheTotalNamingTheCapAndItsOption) {
  WatchStreams streams({3, 10});
  std::vector<WatchStreams::Slot> held;
  for (const char* client : {"10.0.0.1", "10.0.0.2", "10.0.0.3"}) held.push_back(streams.admit(client));
  EXPECT_EQ(streams.open(), 3);
  try {
    streams.admit("10.0.0.4");
    FAIL() << "a fourth stream was admitted under a cap of 3";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kResourceExhausted);
    EXPECT_FALSE(e.too_large());  // load, not size: 429
    EXPECT_NE(std::string(e.what()).find("at most 3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--max-watch-streams)"), std::string::npos) << e.what();
  }
  held.pop_back();  // a stream ends: its slot is given back
  EXPECT_EQ(streams.open(), 2);
  EXPECT_TRUE(streams.admit("10.0.0.4").held());  // a slot not kept is given back at once
  EXPECT_EQ(streams.open(), 2);
}

TEST(WatchStreamCaps, RefuseBeyondTheClientsShareNamingItsAddress) {
  WatchStreams streams({10, 2});
  auto first = streams.admit("10.0.0.1");
  auto second = streams.admit("10.0.0.1");
  try {
    streams.admit("10.0.0.1");
    FAIL() << "a third stream of one client was admitted under a per-client cap of 2";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kResourceExhausted);
    EXPECT_FALSE(e.too_large());
    const std::string message = e.what();
    EXPECT_NE(message.find("10.0.0.1"), std::string::npos) << message;
    EXPECT_NE(message.find("at most 2"), std::string::npos) << message;
    EXPECT_NE(message.find("--max-watch-streams-per-client"), std::string::npos) << message;
  }
  auto other = streams.admit("10.0.0.2");  // another client is not held back
  // A slot moved on is held once and given back once.
  WatchStreams::Slot moved = std::move(first);
  EXPECT_FALSE(first.held());
  EXPECT_TRUE(moved.held());
  EXPECT_EQ(streams.open(), 3);
  moved = WatchStreams::Slot();
  EXPECT_EQ(streams.open(), 2);
  EXPECT_TRUE(streams.admit("10.0.0.1").held());
}

TEST(WatchStreamCaps, AnIpv4MappedAddressIsItsIpv4Client) {
  WatchStreams streams({10, 1});
  auto held = streams.admit("192.0.2.7");
  EXPECT_THROW(streams.admit("::ffff:192.0.2.7"), ApiError);
  EXPECT_TRUE(streams.admit("::ffff:192.0.2.8").held());
  EXPECT_TRUE(streams.admit("2001:db8::7").held());
}

TEST(WatchStreamCaps, ASlotMayOutliveTheCaps) {
  WatchStreams::Slot slot;
  {
    WatchStreams streams({1, 1});
    slot = streams.admit("");
  }
  slot = WatchStreams::Slot();  // gives back into state the slot still shares
  EXPECT_FALSE(slot.held());
}

// ------------------------------------------------------------ a server with a job to watch

// A small H3.6M text tree under `root` (one training file of S1, one test
// file of S5, linked), so that a job prepares its data in a moment.
std::filesystem::path small_data_root(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  for (const char* subject : {"S1", "S5"}) {
    fs::create_directories(root / "h36m" / subject);
    fs::create_symlink(test::h36m_dataset_dir() / subject / "walking_1.txt", root / "h36m" / subject / "walking_1.txt");
  }
  return root;
}

std::vector<std::string> server_args(const test::ScratchDir& scratch) {
  return {"--state-dir", (scratch.path() / "state").string(), "--data-root",
          small_data_root(scratch.path() / "data").string()};
}

httplib::Client patient_client(int port, std::chrono::seconds patience = kPatience) {
  httplib::Client client("127.0.0.1", port);
  const auto seconds = patience.count();
  client.set_connection_timeout(seconds);
  client.set_read_timeout(seconds);
  client.set_write_timeout(seconds);
  return client;
}

// Queues two jobs that train far longer than the test (loopback needs no
// token): the first runs, the second waits behind it and does not change.
// Returns the second's id.
std::string queued_job_to_watch(const ServerProcess& server) {
  auto client = patient_client(server.rest_port());
  client.set_read_timeout(60);
  const json spec = {{"dataset", "h36m"}, {"variant", "D"}, {"iterations", 1000000}, {"hidden", 16}, {"batch", 4}};
  std::string id;
  for (int i = 0; i < 2; ++i) {
    auto reply = client.Post("/v1/jobs", spec.dump(), "application/json");
    if (!reply || reply->status != 200) {
      ADD_FAILURE() << "the job was not submitted: " << (reply ? reply->body : httplib::to_string(reply.error()));
      return "";
    }
    id = json::parse(reply->body).at("id").get<std::string>();
  }
  return id;
}

// Asserts that the calls a client makes are answered while streams are open:
// liveness, readiness and the models within kPatience, an inference call
// within kInferencePatience.
void expect_rest_calls_answered(int port) {
  auto client = patient_client(port);
  for (const char* path : {"/healthz", "/readyz", "/v1/models"}) {
    const auto started = std::chrono::steady_clock::now();
    auto reply = client.Get(path);
    ASSERT_TRUE(reply) << "GET " << path << " not answered: " << httplib::to_string(reply.error());
    EXPECT_EQ(reply->status, 200) << path << ": " << reply->body;
    std::cout << "GET " << path << " with the streams open: "
              << std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count()
              << " ms\n";
  }
  auto inference = patient_client(port, kInferencePatience);
  auto sample = inference.Post("/v1/sample", json{{"count", 1}, {"seed", 3}}.dump(), "application/json");
  ASSERT_TRUE(sample) << "POST /v1/sample not answered: " << httplib::to_string(sample.error());
  EXPECT_EQ(sample->status, 200) << sample->body;
}

// ------------------------------------------------------------ REST event streams on raw sockets

// One HTTP/1.1 GET on a connection of its own from the loopback address
// `source` (127.0.0.0/8: each address is another client to the server), its
// reply read up to the end of the head. Every read waits at most kPatience.
class RawGet {
 public:
  RawGet(int port, const std::string& source, const std::string& path) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    inet_pton(AF_INET, source.c_str(), &local.sin_addr);
    sockaddr_in server{};
    server.sin_family = AF_INET;
    server.sin_port = htons(static_cast<uint16_t>(port));
    inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof(local)) != 0 ||
        ::connect(fd_, reinterpret_cast<sockaddr*>(&server), sizeof(server)) != 0) {
      problem_ = "cannot connect from " + source;
      return;
    }
    const std::string request = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nAccept: text/event-stream\r\n\r\n";
    if (::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(request.size())) {
      problem_ = "cannot send the request";
      return;
    }
    if (!read_until("\r\n\r\n")) {
      problem_ = "no reply within " + std::to_string(kPatience.count()) + " s (the server is starved)";
      return;
    }
    const size_t end = received_.find("\r\n\r\n");
    head_ = received_.substr(0, end);
    received_.erase(0, end + 4);
    status_ = std::atoi(head_.c_str() + head_.find(' ') + 1);
  }
  ~RawGet() { close(); }
  RawGet(const RawGet&) = delete;
  RawGet& operator=(const RawGet&) = delete;

  int status() const { return status_; }  // 0: no reply (see problem())
  const std::string& problem() const { return problem_; }
  // Whether a line of the head is `line` ("Connection: close").
  bool head_says(const std::string& line) const {
    return (head_ + "\r\n").find("\r\n" + line + "\r\n") != std::string::npos;
  }
  // Reads until `text` has come (true), or the connection ends or kPatience
  // passes (false). What came after the head: body().
  bool read_until(const std::string& text) {
    return read([&] { return received_.find(text) != std::string::npos; });
  }
  // Sends another request on the same connection: whether it is answered
  // (a kept-alive connection answers, a closed one cannot).
  bool answers_another(const std::string& path) {
    received_.clear();
    const std::string request = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
    if (::send(fd_, request.data(), request.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(request.size())) return false;
    return read_until("\r\n\r\n");
  }
  const std::string& body() const { return received_; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  template <typename Done>
  bool read(Done&& done) {
    const auto deadline = std::chrono::steady_clock::now() + kPatience;
    while (!done()) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
      pollfd wait{fd_, POLLIN, 0};
      if (closed_ || left <= 0 || ::poll(&wait, 1, static_cast<int>(left)) <= 0) return false;
      char buffer[4096];
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (n <= 0) {
        closed_ = true;
        return done();
      }
      received_.append(buffer, static_cast<size_t>(n));
    }
    return true;
  }

  int fd_ = -1;
  int status_ = 0;
  bool closed_ = false;
  std::string problem_, head_, received_;
};

std::string loopback_address(int n) { return "127.0.0." + std::to_string(n); }

// A refusal of a stream: 429, the error model's body naming `option` and its
// value, and the connection closed rather than kept alive (where it would
// hold a worker for the keep-alive timeout). Returns the message.
std::string expect_refused_stream(RawGet& get, const std::string& option, int cap) {
  EXPECT_EQ(get.status(), 429) << get.body();
  EXPECT_TRUE(get.head_says("Connection: close"));
  if (!get.read_until("}}")) {
    ADD_FAILURE() << "no whole error body: " << get.body();
    return "";
  }
  const json body = json::parse(get.body(), nullptr, false);
  if (body.is_discarded()) {
    ADD_FAILURE() << "the body is not JSON: " << get.body();
    return "";
  }
  EXPECT_EQ(body["error"]["code"], "RESOURCE_EXHAUSTED");
  const std::string message = body["error"]["message"].get<std::string>();
  EXPECT_NE(message.find("at most " + std::to_string(cap)), std::string::npos) << message;
  EXPECT_NE(message.find("(the server's " + option + ")"), std::string::npos) << message;
  EXPECT_FALSE(get.answers_another("/healthz")) << "the refused connection was kept alive";
  return message;
}

TEST(WatchStreams, EventStreamsBeyondTheCapAreRefusedWhileCallsStayAnswered) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  ServerProcess server(server_args(scratch));  // the default caps and worker counts
  const int port = server.rest_port();
  const std::string id = queued_job_to_watch(server);
  ASSERT_FALSE(id.empty());
  const std::string path = "/v1/jobs/" + id + "/events";

  // 200 streams asked for from 25 addresses, 8 each (the per-client cap):
  // the first 64 are served, the rest refused by the total cap.
  std::vector<std::unique_ptr<RawGet>> open;
  int refused = 0;
  for (int i = 0; i < kAskedStreams; ++i) {
    auto get = std::make_unique<RawGet>(port, loopback_address(1 + i / kDefaultPerClientCap), path);
    ASSERT_NE(get->status(), 0) << "stream " << i << ": " << get->problem();
    if (i < kDefaultCap) {
      ASSERT_EQ(get->status(), 200) << "stream " << i << ": " << get->body();
      ASSERT_TRUE(get->read_until("\n\n")) << "stream " << i << " sent no first event";
      EXPECT_NE(get->body().find("\"state\":\"queued\""), std::string::npos) << get->body();
      open.push_back(std::move(get));
    } else {
      expect_refused_stream(*get, "--max-watch-streams", kDefaultCap);
      ++refused;
    }
  }
  EXPECT_EQ(refused, kAskedStreams - kDefaultCap);

  expect_rest_calls_answered(port);
  // The metrics count the open streams (refreshed every second).
  auto client = patient_client(port);
  std::string metrics;
  for (int i = 0; i < 50 && metrics.find("\nmm_watch_streams 64\n") == std::string::npos; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    auto reply = client.Get("/metrics");
    if (reply) metrics = reply->body;
  }
  EXPECT_NE(metrics.find("\nmm_watch_streams 64\n"), std::string::npos) << "no mm_watch_streams 64 in /metrics";

  // A client that leaves gives its slot back: the server finds it gone at
  // the stream's next keep-alive comment (2 s), then admits another.
  open.front()->close();
  bool admitted = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!admitted && std::chrono::steady_clock::now() < deadline) {
    RawGet again(port, loopback_address(100), path);
    ASSERT_NE(again.status(), 0) << again.problem();
    admitted = again.status() == 200;
    if (!admitted) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(admitted) << "a stream's slot was not given back after its client left";

  // Open streams do not hold a shutdown up.
  const auto stopping = std::chrono::steady_clock::now();
  EXPECT_EQ(server.terminate(), 0) << server.log();
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, std::chrono::seconds(30));
}

// ------------------------------------------------------------ gRPC WatchJob streams

std::shared_ptr<grpc::Channel> channel_to(const std::string& target) {
  return grpc::CreateChannel(target, grpc::InsecureChannelCredentials());
}

void within(grpc::ClientContext& context, std::chrono::seconds seconds) {
  context.set_deadline(std::chrono::system_clock::now() + seconds);
}

// A WatchJob stream: admitted when its first record came, else its status.
struct Watch {
  std::unique_ptr<grpc::ClientContext> context = std::make_unique<grpc::ClientContext>();
  std::unique_ptr<grpc::ClientReader<v1::Job>> reader;
  v1::Job first;
  bool admitted = false;
  grpc::Status refusal;

  Watch(v1::MotionManifold::Stub& stub, const std::string& id) {
    // Long enough to outlast the test; the test cancels it.
    within(*context, std::chrono::seconds(300));
    v1::WatchJobRequest request;
    request.set_id(id);
    reader = stub.WatchJob(context.get(), request);
    admitted = reader->Read(&first);
    if (!admitted) refusal = reader->Finish();
  }
  ~Watch() { end(); }
  void end() {
    if (!reader) return;
    if (admitted) {
      context->TryCancel();
      reader->Finish();
    }
    reader.reset();
  }
};

void expect_refused_watch(const Watch& watch, const std::string& option, int cap) {
  EXPECT_EQ(watch.refusal.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << watch.refusal.error_message();
  EXPECT_NE(watch.refusal.error_message().find("at most " + std::to_string(cap)), std::string::npos)
      << watch.refusal.error_message();
  EXPECT_NE(watch.refusal.error_message().find("(the server's " + option + ")"), std::string::npos)
      << watch.refusal.error_message();
}

// Asserts that gRPC calls are answered and health says SERVING while
// streams are open (inference within kInferencePatience, the rest kPatience).
void expect_grpc_calls_answered(const std::string& target) {
  auto stub = v1::MotionManifold::NewStub(channel_to(target));
  {
    grpc::ClientContext context;
    within(context, kPatience);
    v1::ListModelsReply models;
    const auto started = std::chrono::steady_clock::now();
    const auto status = stub->ListModels(&context, v1::ListModelsRequest(), &models);
    ASSERT_TRUE(status.ok()) << "ListModels: " << status.error_message();
    EXPECT_GE(models.models_size(), 1);
    std::cout << "ListModels with the streams open: "
              << std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count()
              << " ms\n";
  }
  {
    grpc::ClientContext context;
    within(context, kInferencePatience);
    v1::SampleRequest request;
    request.set_count(1);
    request.set_seed(3);
    v1::MotionsReply reply;
    const auto status = stub->Sample(&context, request, &reply);
    ASSERT_TRUE(status.ok()) << "Sample: " << status.error_message();
    EXPECT_EQ(reply.motions_size(), 1);
  }
  auto health = grpc::health::v1::Health::NewStub(channel_to(target));
  for (const std::string service : {"", "motionmanifold.v1.MotionManifold"}) {
    grpc::ClientContext context;
    within(context, kPatience);
    grpc::health::v1::HealthCheckRequest request;
    request.set_service(service);
    grpc::health::v1::HealthCheckResponse response;
    const auto status = health->Check(&context, request, &response);
    ASSERT_TRUE(status.ok()) << "health of '" << service << "': " << status.error_message();
    EXPECT_EQ(response.status(), grpc::health::v1::HealthCheckResponse::SERVING) << "'" << service << "'";
  }
}

TEST(WatchStreams, WatchJobStreamsBeyondTheCapAreRefusedWhileCallsStayAnswered) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  // Every stream comes from 127.0.0.1, so the per-client cap is lifted to
  // let one client reach the total; set through its environment variable.
  setenv("MM_MAX_WATCH_STREAMS_PER_CLIENT", "1000", 1);
  std::unique_ptr<ServerProcess> started;
  try {
    started = std::make_unique<ServerProcess>(server_args(scratch));
  } catch (...) {
    unsetenv("MM_MAX_WATCH_STREAMS_PER_CLIENT");
    throw;
  }
  unsetenv("MM_MAX_WATCH_STREAMS_PER_CLIENT");
  ServerProcess& server = *started;
  const std::string id = queued_job_to_watch(server);
  ASSERT_FALSE(id.empty());

  auto stub = v1::MotionManifold::NewStub(channel_to(server.grpc_target()));
  std::vector<std::unique_ptr<Watch>> open;
  int refused = 0;
  for (int i = 0; i < kAskedStreams; ++i) {
    auto watch = std::make_unique<Watch>(*stub, id);
    if (i < kDefaultCap) {
      ASSERT_TRUE(watch->admitted) << "stream " << i << ": " << watch->refusal.error_message();
      EXPECT_EQ(watch->first.state(), "queued");
      open.push_back(std::move(watch));
    } else {
      ASSERT_FALSE(watch->admitted) << "stream " << i << " was admitted beyond the cap";
      expect_refused_watch(*watch, "--max-watch-streams", kDefaultCap);
      ++refused;
    }
  }
  EXPECT_EQ(refused, kAskedStreams - kDefaultCap);

  expect_grpc_calls_answered(server.grpc_target());
  // The REST side is not held back by gRPC's streams either.
  expect_rest_calls_answered(server.rest_port());

  // A cancelled stream gives its slot back at once (the server looks every
  // 50 ms whether its client has gone).
  open.front()->end();
  bool admitted = false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!admitted && std::chrono::steady_clock::now() < deadline) {
    Watch again(*stub, id);
    admitted = again.admitted;
    if (!admitted) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  EXPECT_TRUE(admitted) << "a cancelled stream's slot was not given back";

  const auto stopping = std::chrono::steady_clock::now();
  EXPECT_EQ(server.terminate(), 0) << server.log();
  EXPECT_LT(std::chrono::steady_clock::now() - stopping, std::chrono::seconds(30));
}

// ------------------------------------------------------------ one client over both protocols

TEST(WatchStreams, OneClientAddressHoldsAtMostItsShareOverBothProtocols) {
  MM_REQUIRE_H36M();
  const test::ScratchDir scratch;
  ServerProcess server(server_args(scratch));  // the default caps
  const std::string id = queued_job_to_watch(server);
  ASSERT_FALSE(id.empty());
  const std::string path = "/v1/jobs/" + id + "/events";
  auto stub = v1::MotionManifold::NewStub(channel_to(server.grpc_target()));

  // Half of 127.0.0.1's share over gRPC, half over REST.
  std::vector<std::unique_ptr<Watch>> watches;
  std::vector<std::unique_ptr<RawGet>> streams;
  for (int i = 0; i < kDefaultPerClientCap / 2; ++i) {
    watches.push_back(std::make_unique<Watch>(*stub, id));
    ASSERT_TRUE(watches.back()->admitted) << watches.back()->refusal.error_message();
    streams.push_back(std::make_unique<RawGet>(server.rest_port(), "127.0.0.1", path));
    ASSERT_EQ(streams.back()->status(), 200) << streams.back()->problem() << streams.back()->body();
  }
  // One more from that address is refused by either protocol, naming the
  // per-client cap.
  RawGet over_rest(server.rest_port(), "127.0.0.1", path);
  const std::string message = expect_refused_stream(over_rest, "--max-watch-streams-per-client", kDefaultPerClientCap);
  EXPECT_NE(message.find("from 127.0.0.1"), std::string::npos) << message;
  Watch over_grpc(*stub, id);
  ASSERT_FALSE(over_grpc.admitted);
  expect_refused_watch(over_grpc, "--max-watch-streams-per-client", kDefaultPerClientCap);
  // Another address still gets its streams, and calls from the full one
  // are still answered.
  RawGet other(server.rest_port(), "127.0.0.2", path);
  EXPECT_EQ(other.status(), 200) << other.problem() << other.body();
  expect_rest_calls_answered(server.rest_port());
  expect_grpc_calls_answered(server.grpc_target());
  // Refusals are the only answers that differ: an unknown job is still 404.
  RawGet unknown(server.rest_port(), "127.0.0.1", "/v1/jobs/no-such-job/events");
  EXPECT_EQ(unknown.status(), 404) << unknown.body();
}

}  // namespace
}  // namespace mm
