// The REST frontend under hostile traffic, through a real server on loopback
// and raw sockets: slow clients capped per address and cut at the head's
// deadline while the probes and a Sample stay answered; a body sent too
// slowly cut at its own; heads refused by RFC 9112 before they are read
// whole (too many fields, lines too long); bodies framed one way only
// (Content-Length with Transfer-Encoding, an unknown coding, Content-Lengths
// that disagree), with the request hidden behind them never run; control
// characters, NUL included, refused in every header; TLS handshakes held to
// the head's deadline. Every test sets short limits through the server's
// options.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <iterator>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

using Clock = std::chrono::steady_clock;
using json = nlohmann::json;
using namespace std::chrono_literals;

const char* const kToken = "hostile-traffic-test-token-5d1c";

// Short limits, so that each deadline passes within the test's seconds.
std::vector<std::string> server_args(std::vector<std::string> more = {}) {
  std::vector<std::string> args = {"--auth-token",
                                   kToken,
                                   "--rest-header-timeout-seconds",
                                   "2",
                                   "--rest-body-timeout-seconds",
                                   "2",
                                   "--rest-max-connections-per-client",
                                   "8",
                                   // 16 workers: fewer than the slow clients below,
                                   // so that without the cap they would hold them all.
                                   "--rest-threads",
                                   "8",
                                   "--max-watch-streams",
                                   "8",
                                   // One inference thread: the thread count's tuner
                                   // times batches in the first seconds otherwise,
                                   // which slows a Sample then whatever the traffic.
                                   "--threads",
                                   "1"};
  args.insert(args.end(), more.begin(), more.end());
  return args;
}

// A TCP connection to the server from a loopback address of our choosing
// (every 127.0.0.0/8 address is this machine's), so that one test's clients
// count as different addresses against the per-client cap.
class RawConnection {
 public:
  RawConnection(int port, const std::string& from = "127.0.0.1") {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in local{};
    local.sin_family = AF_INET;
    ::inet_pton(AF_INET, from.c_str(), &local.sin_addr);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) {
      close();
      return;
    }
    sockaddr_in server{};
    server.sin_family = AF_INET;
    server.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &server.sin_addr);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&server), sizeof server) != 0) {
      close();
      return;
    }
    timeval timeout{10, 0};  // no send waits for ever on a server that stopped reading
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof timeout);
  }
  ~RawConnection() { close(); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  bool open() const { return fd_ >= 0; }
  // Sends all of `bytes`; the count sent before an error.
  size_t send(const std::string& bytes) {
    size_t sent = 0;
    while (fd_ >= 0 && sent < bytes.size()) {
      const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
      if (n <= 0) break;
      sent += static_cast<size_t>(n);
    }
    return sent;
  }
  // What has arrived within `wait`, until the server closes (`closed`).
  std::string receive(std::chrono::milliseconds wait, bool* closed = nullptr) {
    std::string received;
    const auto until = Clock::now() + wait;
    if (closed) *closed = false;
    while (fd_ >= 0) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count();
      if (left <= 0) break;
      pollfd entry{fd_, POLLIN, 0};
      if (::poll(&entry, 1, static_cast<int>(left)) <= 0) break;
      char chunk[16384];
      const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
      if (n <= 0) {
        if (closed) *closed = true;
        break;
      }
      received.append(chunk, static_cast<size_t>(n));
    }
    return received;
  }
  // Whether the server closed the connection within `wait` (bytes before
  // the end are dropped).
  bool closed_within(std::chrono::milliseconds wait) {
    bool closed = false;
    receive(wait, &closed);
    return closed;
  }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  int fd_ = -1;
};

// The status of the first reply in `bytes` (0 when there is none).
int status_of(const std::string& bytes) {
  if (bytes.rfind("HTTP/1.1 ", 0) != 0 || bytes.size() < 12) return 0;
  return std::atoi(bytes.substr(9, 3).c_str());
}

// How many replies `bytes` holds (status lines: a message may say HTTP/1.1).
size_t replies_in(const std::string& bytes) {
  static const std::regex status_line("HTTP/1\\.1 [0-9]{3} ");
  return static_cast<size_t>(
      std::distance(std::sregex_iterator(bytes.begin(), bytes.end(), status_line), std::sregex_iterator()));
}

std::string request(const std::string& method, const std::string& path, const std::string& headers,
                    const std::string& body = "") {
  return method + " " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + headers + "\r\n" + body;
}

// The request hidden behind a smuggling attempt: it activates the other
// model, which the default model's `active` flag shows.
std::string hidden_activation() {
  return request("POST", "/v1/models/h36m-dkgm-cpu:activate",
                 "Authorization: Bearer " + std::string(kToken) + "\r\nContent-Length: 0\r\n");
}

bool default_model_active(int port) {
  const test::Reply model = test::get(port, "/v1/models/h36m-dkgm-h100");
  EXPECT_EQ(model.status, 200) << model.body;
  return model.status == 200 && model.document["active"].get<bool>();
}

// Sends `bytes` on a fresh connection; expects the reply `status` whose
// message names `named`, then the connection closed, with nothing run after.
void expect_refused_and_closed(int port, const std::string& bytes, int status, const std::string& named) {
  RawConnection connection(port);
  ASSERT_TRUE(connection.open());
  connection.send(bytes);
  bool closed = false;
  const std::string reply = connection.receive(5000ms, &closed);
  EXPECT_EQ(status_of(reply), status) << reply;
  EXPECT_NE(reply.find(named), std::string::npos) << reply;
  EXPECT_EQ(replies_in(reply), 1u) << "a request after the refused one was answered: " << reply;
  EXPECT_TRUE(closed) << "the connection was kept open after " << reply;
}

class RestHostileTraffic : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { server_ = new test::ServerProcess(server_args()); }
  static void TearDownTestSuite() {
    delete server_;
    server_ = nullptr;
  }
  static int port() { return server_->rest_port(); }
  static test::ServerProcess* server_;
};
test::ServerProcess* RestHostileTraffic::server_ = nullptr;

// ---------------------------------------------------------------- slow clients

// An HTTP probe from `from` on a fresh connection: the reply's status, or 0
// when none came within `wait`.
int probe(int port, const std::string& from, const std::string& bytes, std::chrono::milliseconds wait) {
  RawConnection connection(port, from);
  if (!connection.open()) return 0;
  connection.send(bytes);
  return status_of(connection.receive(wait));
}

TEST_F(RestHostileTraffic, SlowHeadersAreCappedPerClientAndCutAtTheDeadlineWhileProbesAreAnswered) {
  // 200 clients from one address send a head a byte a second, which
  // httplib's read timeout (5 s a read) alone would let go on for ever.
  constexpr int kSlowClients = 200;
  const std::string head = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
  // A first Sample before, so that what is timed below is the slow
  // clients' effect, not the model's first run.
  const std::string sample_body = R"({"count": 1, "seed": 3})";
  const std::string sample = request("POST", "/v1/sample",
                                     "Content-Type: application/json\r\nContent-Length: " +
                                         std::to_string(sample_body.size()) + "\r\nConnection: close\r\n",
                                     sample_body);
  ASSERT_EQ(probe(port(), "127.0.0.2", sample, 60000ms), 200);
  std::vector<std::unique_ptr<RawConnection>> slow;
  const auto started = Clock::now();
  for (int i = 0; i < kSlowClients; ++i) {
    slow.push_back(std::make_unique<RawConnection>(port(), "127.0.0.3"));
    slow.back()->send(head.substr(0, 1));
  }
  std::atomic<bool> trickling{true};
  std::thread trickle([&] {
    for (size_t byte = 1; trickling; ++byte) {
      for (auto& connection : slow) connection->send("a");
      std::this_thread::sleep_for(1s);
    }
  });
  // Meanwhile the probes and a Sample from another address are answered
  // within 2 s each.
  const std::string healthz = request("GET", "/healthz", "Connection: close\r\n");
  int healthz_answered = 0, samples_answered = 0;
  Clock::duration slowest{};
  const auto timed_probe = [&](const std::string& bytes) {
    const auto sent = Clock::now();
    const int status = probe(port(), "127.0.0.2", bytes, 2000ms);
    slowest = std::max(slowest, Clock::now() - sent);
    return status;
  };
  for (int round = 0; round < 4; ++round) {
    healthz_answered += timed_probe(healthz) == 200;
    samples_answered += timed_probe(sample) == 200;
    std::this_thread::sleep_for(500ms);
  }
  RecordProperty("slowest_probe_ms",
                 static_cast<int>(std::chrono::duration_cast<std::chrono::milliseconds>(slowest).count()));
  EXPECT_EQ(healthz_answered, 4);
  EXPECT_EQ(samples_answered, 4);

  // Those over the cap (8) were answered 429 naming it at once; those under
  // it 408 naming the head's deadline (2 s) while they were still sending.
  std::this_thread::sleep_until(started + 3500ms);
  size_t capped = 0, timed_out = 0;
  std::string a_refusal, a_timeout;
  for (auto& connection : slow) {
    const std::string reply = connection->receive(100ms);
    if (status_of(reply) == 429) {
      ++capped;
      a_refusal = reply;
    } else if (status_of(reply) == 408) {
      ++timed_out;
      a_timeout = reply;
    }
  }
  trickling = false;
  trickle.join();
  EXPECT_EQ(capped, static_cast<size_t>(kSlowClients - 8));
  EXPECT_EQ(timed_out, 8u);
  EXPECT_NE(a_refusal.find("--rest-max-connections-per-client"), std::string::npos) << a_refusal;
  EXPECT_NE(a_timeout.find("--rest-header-timeout-seconds"), std::string::npos) << a_timeout;
}

TEST_F(RestHostileTraffic, ABodySentTooSlowlyIsCutAtItsDeadline) {
  RawConnection connection(port());
  connection.send(request("POST", "/v1/sample", "Content-Type: application/json\r\nContent-Length: 100\r\n"));
  // Ten bytes every half second: each read well within httplib's 5 s, the
  // whole body (100 bytes) not within the body's 2 s.
  std::string reply;
  bool closed = false;
  for (int i = 0; i < 10 && !closed && reply.empty(); ++i) {
    connection.send(std::string(10, ' '));
    reply = connection.receive(500ms, &closed);
  }
  if (reply.empty()) reply = connection.receive(1000ms, &closed);
  EXPECT_EQ(status_of(reply), 408) << reply;
  EXPECT_NE(reply.find("--rest-body-timeout-seconds"), std::string::npos) << reply;
}

// ---------------------------------------------------------------- heads read by the book

TEST_F(RestHostileTraffic, TooManyHeaderFieldsAreRefused) {
  std::string fields;
  for (int i = 0; i < 1000; ++i) fields += "X-Field-" + std::to_string(i) + ": v\r\n";
  expect_refused_and_closed(port(), request("GET", "/healthz", fields), 431, "--rest-max-headers");
}

// Sends `head` then up to 64 MiB of one line that never ends, on a thread
// of its own, while the reply is read here: the refusal comes, and the
// server stopped reading long before 64 MiB.
void expect_long_line_refused_early(int port, const std::string& head, int status) {
  constexpr size_t kLine = size_t{64} << 20;
  RawConnection connection(port);
  ASSERT_TRUE(connection.open());
  std::atomic<size_t> sent{0};
  std::thread sender([&] {
    const std::string chunk(1 << 20, 'a');
    sent += connection.send(head);
    for (size_t total = 0; total < kLine; total += chunk.size()) {
      const size_t n = connection.send(chunk);
      sent += n;
      if (n < chunk.size()) break;
    }
  });
  const std::string reply = connection.receive(10000ms);
  sender.join();
  EXPECT_EQ(status_of(reply), status) << reply.substr(0, 300);
  EXPECT_NE(reply.find("--rest-max-line-bytes"), std::string::npos) << reply.substr(0, 300);
  // What the kernel buffers on loopback is a few MiB at most.
  EXPECT_LT(sent.load(), kLine / 4) << "the server read " << sent.load() << " bytes of the line";
}

TEST_F(RestHostileTraffic, AnOverlongHeaderLineIsRefusedBeforeItArrivesWhole) {
  expect_long_line_refused_early(port(), "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Long: ", 431);
}

TEST_F(RestHostileTraffic, AnOverlongRequestLineIsRefusedBeforeItArrivesWhole) {
  expect_long_line_refused_early(port(), "GET /healthz?padding=", 414);
}

// ---------------------------------------------------------------- one framing of a body

TEST_F(RestHostileTraffic, ContentLengthWithChunkedIsRefusedAndTheHiddenRequestNeverRuns) {
  // A front end that frames by Content-Length sees one request; httplib
  // framed it by the chunks and ran what followed them as a second.
  const std::string after_head = "2\r\n{}\r\n0\r\n\r\n" + hidden_activation();
  expect_refused_and_closed(port(),
                            request("POST", "/v1/sample",
                                    "Content-Type: application/json\r\nContent-Length: " +
                                        std::to_string(after_head.size()) + "\r\nTransfer-Encoding: chunked\r\n",
                                    after_head),
                            400, "both Transfer-Encoding and Content-Length");
  EXPECT_TRUE(default_model_active(port()));
}

TEST_F(RestHostileTraffic, AnUnknownTransferCodingIsRefusedAndTheHiddenRequestNeverRuns) {
  // httplib took "xchunked" as no coding and framed the body by its length.
  expect_refused_and_closed(port(),
                            request("POST", "/v1/sample",
                                    "Content-Type: application/json\r\nContent-Length: 2\r\n"
                                    "Transfer-Encoding: xchunked\r\n",
                                    "{}" + hidden_activation()),
                            400, "Transfer-Encoding");
  expect_refused_and_closed(port(),
                            request("POST", "/v1/sample",
                                    "Content-Type: application/json\r\nTransfer-Encoding: xchunked\r\n",
                                    "2\r\n{}\r\n0\r\n\r\n" + hidden_activation()),
                            400, "does not end in chunked");
  EXPECT_TRUE(default_model_active(port()));
}

TEST_F(RestHostileTraffic, ContentLengthsThatDisagreeAreRefusedOnEveryMethod) {
  const std::string hidden = hidden_activation();
  // httplib framed by the first and ran the rest as a request.
  expect_refused_and_closed(port(),
                            request("GET", "/healthz",
                                    "Content-Length: 0\r\nContent-Length: " + std::to_string(hidden.size()) + "\r\n",
                                    hidden),
                            400, "two Content-Length headers that disagree");
  expect_refused_and_closed(port(),
                            request("POST", "/v1/sample",
                                    "Content-Type: application/json\r\nContent-Length: 2\r\nContent-Length: " +
                                        std::to_string(2 + hidden.size()) + "\r\n",
                                    "{}" + hidden),
                            400, "two Content-Length headers that disagree");
  expect_refused_and_closed(port(),
                            request("DELETE", "/v1/models/missing",
                                    "Content-Length: 1\r\nContent-Length: 0\r\n", "x"),
                            400, "two Content-Length headers that disagree");
  EXPECT_TRUE(default_model_active(port()));
}

// ---------------------------------------------------------------- control characters

TEST_F(RestHostileTraffic, ANulAfterTheTokenIsRefusedAndNothingChanges) {
  // httplib cut the value at the NUL, so the token looked whole.
  const std::string with_nul = "Authorization: Bearer " + std::string(kToken) + std::string(1, '\0') + "\r\n";
  expect_refused_and_closed(port(),
                            request("POST", "/v1/models/h36m-dkgm-cpu:activate", with_nul + "Content-Length: 0\r\n"),
                            400, "the control character 0x00");
  EXPECT_TRUE(default_model_active(port()));
}

TEST_F(RestHostileTraffic, ControlCharactersInAnyHeaderAreRefused) {
  const std::vector<std::string> fields = {
      "X-Note: a" + std::string(1, '\x01') + "b\r\n",   // in a value
      "X-Note: a" + std::string(1, '\x7f') + "b\r\n",   // DEL
      "User-Agent: a" + std::string(1, '\0') + "b\r\n",  // NUL in another header
      "X-Note: a\rb\r\n",                                // a bare CR
      "X-No" + std::string(1, '\x02') + "te: v\r\n",     // in a name
  };
  for (const std::string& field : fields) {
    SCOPED_TRACE(testing::PrintToString(field));
    expect_refused_and_closed(port(), request("GET", "/healthz", field), 400, "0x");
  }
  // A bare LF ends no line, and a space before the colon makes no name.
  expect_refused_and_closed(port(), "GET /healthz HTTP/1.1\r\nHost: x\nX-Note: v\r\n\r\n", 400, "bare LF");
  expect_refused_and_closed(port(), request("GET", "/healthz", "X-Note : v\r\n"), 400, "no space before the colon");
}

// ---------------------------------------------------------------- what still works

TEST_F(RestHostileTraffic, WellFormedRequestsAreStillServedPipelinedAndChunked) {
  RawConnection connection(port());
  // Two requests in one write: both answered, the connection kept.
  connection.send(request("GET", "/healthz", "") + request("GET", "/readyz", ""));
  std::string replies;
  for (int i = 0; i < 20 && replies_in(replies) < 2; ++i) replies += connection.receive(250ms);
  EXPECT_EQ(replies_in(replies), 2u) << replies;
  EXPECT_EQ(status_of(replies), 200) << replies;
  // A chunked body, an identical repeated Content-Length, a token with
  // blanks around it.
  const std::string chunked = request("POST", "/v1/sample",
                                      "Content-Type: application/json\r\nTransfer-Encoding: chunked\r\n",
                                      "b\r\n{\"count\": 1\r\n1\r\n}\r\n0\r\n\r\n");
  EXPECT_EQ(probe(port(), "127.0.0.1", chunked, 10000ms), 200);
  const std::string twice = request("POST", "/v1/sample",
                                    "Content-Type: application/json\r\nContent-Length: 2\r\nContent-Length: 2\r\n"
                                    "Connection: close\r\n",
                                    "{}");
  EXPECT_EQ(probe(port(), "127.0.0.1", twice, 10000ms), 200);
  const test::Reply listed = test::get(port(), "/v1/clips", {{"Authorization", "Bearer  " + std::string(kToken) + " "}});
  EXPECT_NE(listed.status, 401) << listed.body;
}

// ---------------------------------------------------------------- TLS

TEST(RestHostileTls, ASlowHandshakeIsCutAtTheHeadDeadlineAndTlsStillServes) {
  const std::string dir = ::testing::TempDir();
  const std::string cert = dir + "/hostile-cert.pem", key = dir + "/hostile-key.pem";
  const std::string command = "openssl req -x509 -newkey rsa:2048 -nodes -days 1 -subj /CN=127.0.0.1 -keyout " + key +
                              " -out " + cert + " > /dev/null 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << "openssl could not make a test certificate";
  test::ServerProcess server(server_args({"--tls-cert", cert, "--tls-key", key}));
  // The first bytes of a ClientHello, a byte a second: httplib's handshake
  // waited 5 s a read, for ever.
  RawConnection slow(server.rest_port());
  const std::string hello_start("\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03", 11);
  bool closed = false;
  for (size_t i = 0; i < hello_start.size() && !closed; ++i) {
    slow.send(hello_start.substr(i, 1));
    slow.receive(1000ms, &closed);
  }
  EXPECT_TRUE(closed) << "the handshake was still waiting after " << hello_start.size() << " s";
  httplib::SSLClient tls("127.0.0.1", server.rest_port());
  tls.enable_server_certificate_verification(false);
  tls.set_read_timeout(60);
  const auto healthz = tls.Get("/healthz");
  ASSERT_TRUE(healthz) << httplib::to_string(healthz.error());
  EXPECT_EQ(healthz->status, 200);
  const auto sample = tls.Post("/v1/sample", json{{"count", 1}, {"seed", 2}}.dump(), "application/json");
  ASSERT_TRUE(sample) << httplib::to_string(sample.error());
  EXPECT_EQ(sample->status, 200) << sample->body;
}

}  // namespace
}  // namespace mm
