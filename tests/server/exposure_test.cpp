// A server exposed to the network as scripts/serve.sh starts it (listening on
// 0.0.0.0 with training jobs and a data root, no token), called from an
// address of this machine that is not loopback: every call that changes
// state, and every clip read, is refused over both protocols with
// UNAUTHENTICATED naming the fix, and nothing changed; the same calls from
// loopback go through; reads of the model stay open. With a token, the
// network gets in with it, and --public-clips opens the clips alone. The
// Authorization header is read the same way by both frontends, by the one
// parser of core/caller_identity.h, on the same table of headers.
#include <gtest/gtest.h>
#include <grpcpp/grpcpp.h>
#include <httplib.h>
#include <ifaddrs.h>
#include <net/if.h>
#include <netdb.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "motionmanifold/v1/manifold.grpc.pb.h"
#include "server/core/caller_identity.h"
#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::motionmanifold::v1;
using json = nlohmann::json;
using service::BearerCredentials;
using service::parse_authorization;

const char* const kClip = "h36m/S5/walking_1.txt";
const char* const kToken = "exposure-test-token-7f3a";

// An IPv4 address of an interface of this machine that is up and not
// loopback: connecting to it from here, the server sees that address as its
// peer, as it would see another machine. Empty when the machine has none.
std::string non_loopback_address() {
  ifaddrs* interfaces = nullptr;
  if (getifaddrs(&interfaces) != 0) return "";
  std::string found;
  for (const ifaddrs* i = interfaces; i != nullptr && found.empty(); i = i->ifa_next) {
    if (i->ifa_addr == nullptr || i->ifa_addr->sa_family != AF_INET) continue;
    if ((i->ifa_flags & IFF_UP) == 0 || (i->ifa_flags & IFF_LOOPBACK) != 0) continue;
    char host[NI_MAXHOST];
    if (getnameinfo(i->ifa_addr, sizeof(sockaddr_in), host, sizeof host, nullptr, 0, NI_NUMERICHOST) != 0) continue;
    if (!service::is_loopback_ip(host)) found = host;
  }
  freeifaddrs(interfaces);
  return found;
}

fs::path make_data_root(const fs::path& root) {
  fs::create_directories(root / "h36m" / "S5");
  fs::copy_file(test::h36m_dataset_dir() / "S5" / "walking_1.txt", root / kClip);
  return root;
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// A caller at `host`: REST and gRPC clients of the server's two ports.
struct Caller {
  Caller(const std::string& host, const test::ServerProcess& server)
      : rest(host, server.rest_port()),
        stub(v1::MotionManifold::NewStub(grpc::CreateChannel(host + ":" + std::to_string(server.grpc_port()),
                                                             grpc::InsecureChannelCredentials()))) {
    rest.set_connection_timeout(10);
    rest.set_read_timeout(300);
  }
  test::Reply post(const std::string& path, const std::string& body, const httplib::Headers& headers = {}) {
    return test::to_reply(rest.Post(path.c_str(), headers, body, "application/json"));
  }
  test::Reply get(const std::string& path, const httplib::Headers& headers = {}) {
    return test::to_reply(rest.Get(path.c_str(), headers));
  }
  httplib::Client rest;
  std::unique_ptr<v1::MotionManifold::Stub> stub;
};

// One state-changing or clip-reading call over REST and its gRPC twin.
struct GuardedCall {
  std::string name;
  std::function<test::Reply(Caller&, const httplib::Headers&)> rest;
  std::function<grpc::Status(Caller&, grpc::ClientContext&)> grpc;
};

std::vector<GuardedCall> guarded_calls(const std::string& upload_content) {
  const json job = {{"dataset", "h36m"}, {"variant", "DKGM"}, {"iterations", 2}, {"hidden", 16}};
  return {
      {"activate",
       [](Caller& c, const httplib::Headers& h) { return c.post("/v1/models/h36m-dkgm-cpu:activate", "{}", h); },
       [](Caller& c, grpc::ClientContext& context) {
         v1::ActivateModelRequest request;
         request.set_model("h36m-dkgm-cpu");
         v1::ModelInfo reply;
         return c.stub->ActivateModel(&context, request, &reply);
       }},
      {"upload",
       [upload_content](Caller& c, const httplib::Headers& h) {
         return c.post("/v1/clips:upload?path=mine%2Frest.txt", upload_content, h);
       },
       [upload_content](Caller& c, grpc::ClientContext& context) {
         v1::UploadClipRequest request;
         request.set_path("mine/grpc.txt");
         request.set_content(upload_content);
         v1::ClipFile reply;
         return c.stub->UploadClip(&context, request, &reply);
       }},
      {"submit", [job](Caller& c, const httplib::Headers& h) { return c.post("/v1/jobs", job.dump(), h); },
       [](Caller& c, grpc::ClientContext& context) {
         v1::SubmitJobRequest request;
         request.mutable_spec()->set_dataset("h36m");
         request.mutable_spec()->set_variant("DKGM");
         v1::Job reply;
         return c.stub->SubmitJob(&context, request, &reply);
       }},
      {"cancel", [](Caller& c, const httplib::Headers& h) { return c.post("/v1/jobs/0123456789ab:cancel", "{}", h); },
       [](Caller& c, grpc::ClientContext& context) {
         v1::CancelJobRequest request;
         request.set_id("0123456789ab");
         v1::Job reply;
         return c.stub->CancelJob(&context, request, &reply);
       }},
      {"list clips", [](Caller& c, const httplib::Headers& h) { return c.get("/v1/clips", h); },
       [](Caller& c, grpc::ClientContext& context) {
         v1::ListClipsReply reply;
         return c.stub->ListClips(&context, v1::ListClipsRequest(), &reply);
       }},
      {"read clip",
       [](Caller& c, const httplib::Headers& h) {
         return c.get("/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt&model=h36m-dkgm-cpu", h);
       },
       [](Caller& c, grpc::ClientContext& context) {
         v1::ReadClipRequest request;
         request.set_path(kClip);
         request.set_model("h36m-dkgm-cpu");
         v1::ReadClipReply reply;
         return c.stub->ReadClip(&context, request, &reply);
       }},
      // The whole file (ReadClipRequest.whole) is a clip read as well.
      {"read whole clip",
       [](Caller& c, const httplib::Headers& h) {
         return c.get("/v1/clips/motion?path=h36m%2FS5%2Fwalking_1.txt&model=h36m-dkgm-cpu", h);
       },
       [](Caller& c, grpc::ClientContext& context) {
         v1::ReadClipRequest request;
         request.set_path(kClip);
         request.set_model("h36m-dkgm-cpu");
         request.set_whole(true);
         v1::ReadClipReply reply;
         return c.stub->ReadClip(&context, request, &reply);
       }},
  };
}

class ExposedServer : public ::testing::Test {
 protected:
  void SetUp() override {
    MM_REQUIRE_H36M();
    address_ = non_loopback_address();
    ASSERT_FALSE(address_.empty()) << "this machine has no non-loopback IPv4 address to call the server from";
    data_root_ = make_data_root(scratch_.path() / "data");
    upload_content_ = file_bytes(data_root_ / kClip);
  }

  // Started as scripts/serve.sh starts it: every address, jobs, a data root.
  std::unique_ptr<test::ServerProcess> serve(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--address", "0.0.0.0", "--state-dir", (scratch_.path() / "state").string(),
                                     "--data-root", data_root_.string()};
    args.insert(args.end(), extra.begin(), extra.end());
    return std::make_unique<test::ServerProcess>(args);
  }

  std::string active_model(Caller& caller) {
    const auto reply = caller.get("/v1/models");
    for (const auto& model : reply.document.at("models")) {
      if (model.value("active", false)) return model.at("name").get<std::string>();
    }
    return "";
  }

  test::ScratchDir scratch_;
  std::string address_;
  fs::path data_root_;
  std::string upload_content_;
};

TEST_F(ExposedServer, WithoutATokenTheNetworkCannotChangeStateOrReadClips) {
  const auto server = serve();
  Caller remote(address_, *server);
  Caller local("127.0.0.1", *server);

  for (const auto& call : guarded_calls(upload_content_)) {
    const auto reply = call.rest(remote, {});
    EXPECT_EQ(reply.status, 401) << call.name << ": " << reply.body;
    if (reply.status != 401) continue;
    EXPECT_EQ(reply.field(), "authorization") << call.name;
    const std::string message = reply.error().at("message").get<std::string>();
    EXPECT_NE(message.find("only from loopback"), std::string::npos) << call.name << ": " << message;
    EXPECT_NE(message.find(address_), std::string::npos) << call.name << ": " << message;
    EXPECT_NE(message.find("--auth-token-file"), std::string::npos) << call.name << ": " << message;
    EXPECT_EQ(reply.header("WWW-Authenticate"), "Bearer") << call.name;

    grpc::ClientContext context;
    const auto status = call.grpc(remote, context);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << call.name << ": " << status.error_message();
    EXPECT_NE(status.error_message().find("only from loopback"), std::string::npos) << status.error_message();
  }
  // Nothing changed.
  EXPECT_EQ(active_model(local), "h36m-dkgm-h100");
  EXPECT_FALSE(fs::exists(data_root_ / "mine"));
  EXPECT_EQ(local.get("/v1/jobs").document.at("jobs").size(), 0u);
  // The model itself stays open to the network.
  EXPECT_EQ(remote.get("/v1/models").status, 200);
  EXPECT_EQ(remote.post("/v1/sample", R"({"count": 1, "seed": 3, "model": "h36m-dkgm-cpu"})").status, 200);
  // The operator was told at start.
  EXPECT_NE(server->log().find("listening beyond loopback (0.0.0.0) without a token"), std::string::npos)
      << server->log();

  // From loopback the same calls go through (the job id is unknown: 404,
  // past the check; the submission names a dataset that is not one: 400).
  EXPECT_EQ(local.post("/v1/models/h36m-dkgm-cpu:activate", "{}").status, 200);
  EXPECT_EQ(active_model(local), "h36m-dkgm-cpu");
  EXPECT_EQ(local.post("/v1/clips:upload?path=mine%2Frest.txt", upload_content_).status, 200);
  EXPECT_TRUE(fs::exists(data_root_ / "mine" / "rest.txt"));
  EXPECT_EQ(local.post("/v1/jobs/0123456789ab:cancel", "{}").status, 404);
  EXPECT_EQ(local.get("/v1/clips").status, 200);
  EXPECT_EQ(local.get("/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt").status, 200);
  EXPECT_EQ(local.get("/v1/clips/motion?path=h36m%2FS5%2Fwalking_1.txt").status, 200);
}

TEST_F(ExposedServer, WithATokenTheNetworkGetsInWithItAndPublicClipsOpenOnlyTheClips) {
  const fs::path token_file = scratch_.path() / "token";
  std::ofstream(token_file) << kToken << "\n";
  fs::permissions(token_file, fs::perms::owner_read | fs::perms::owner_write);
  const auto server = serve({"--auth-token-file", token_file.string(), "--public-clips"});
  Caller remote(address_, *server);
  Caller local("127.0.0.1", *server);

  // Without the token, from anywhere, loopback included: refused.
  for (Caller* caller : {&remote, &local}) {
    const auto reply = caller->post("/v1/models/h36m-dkgm-cpu:activate", "{}");
    EXPECT_EQ(reply.status, 401) << reply.body;
  }
  // The clips are public: no token needed.
  EXPECT_EQ(remote.get("/v1/clips").status, 200);
  EXPECT_EQ(remote.get("/v1/clips/window?path=h36m%2FS5%2Fwalking_1.txt").status, 200);
  EXPECT_EQ(remote.get("/v1/clips/motion?path=h36m%2FS5%2Fwalking_1.txt").status, 200);
  // With the token, the network changes state.
  EXPECT_EQ(remote.post("/v1/models/h36m-dkgm-cpu:activate", "{}", test::bearer(kToken)).status, 200);
  grpc::ClientContext context;
  context.AddMetadata("authorization", std::string("Bearer ") + kToken);
  v1::ActivateModelRequest request;
  request.set_model("h36m-dkgm-h100");
  v1::ModelInfo info;
  const auto status = remote.stub->ActivateModel(&context, request, &info);
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_EQ(active_model(local), "h36m-dkgm-h100");
}

// The one parser, on its own: what each header gives.
TEST(AuthorizationHeader, OneParserReadsEveryFormTheSameWay) {
  struct Case {
    std::vector<std::string> headers;
    std::string token;    // expected token ("" when none)
    std::string problem;  // a part of the expected problem ("" when none)
  };
  const std::string long_token(10 * 1024, 'a');
  const std::vector<Case> cases = {
      {{}, "", ""},
      {{""}, "", ""},
      {{" \t "}, "", ""},
      {{"", "Bearer abc"}, "abc", ""},
      {{"Bearer"}, "", "no token"},
      {{"Bearer   "}, "", "no token"},
      {{"Basic dXNlcjpwYXNz"}, "", "found \"Basic\""},
      {{"Bearerabc"}, "", "found \"Bearerabc\""},
      {{"Bearer abc"}, "abc", ""},
      {{"bearer abc"}, "abc", ""},
      {{"BEARER abc"}, "abc", ""},
      {{"  Bearer \t abc \t "}, "abc", ""},
      {{"Bearer abc def"}, "", "space or a control"},
      {{std::string("Bearer ab\0c", 11)}, "", "control"},
      {{"Bearer ab\x7f"}, "", "control"},
      {{"Bearer abc", "Bearer abc"}, "", "one Authorization header, found 2"},
      {{"Bearer " + long_token}, "", "longer than 4096 bytes"},
  };
  for (const auto& c : cases) {
    const std::string shown = c.headers.empty() ? "(none)" : c.headers.front().substr(0, 40);
    const BearerCredentials credentials = parse_authorization(c.headers);
    EXPECT_EQ(credentials.token, c.token) << shown;
    if (c.problem.empty()) {
      EXPECT_EQ(credentials.problem, "") << shown;
    } else {
      EXPECT_NE(credentials.problem.find(c.problem), std::string::npos) << shown << ": " << credentials.problem;
    }
  }
  EXPECT_TRUE(service::tokens_equal("abc", "abc"));
  for (const char* wrong : {"", "ab", "abd", "abcd", "bbc"}) EXPECT_FALSE(service::tokens_equal(wrong, "abc")) << wrong;
  EXPECT_FALSE(service::tokens_equal("", ""));
}

// A client has one address whichever frontend it called: an IPv4-mapped
// IPv6 address is its IPv4 address, loopback or not.
TEST(CallerAddress, AnIpv4MappedAddressIsItsIpv4Address) {
  EXPECT_EQ(service::canonical_ip("::ffff:192.0.2.7"), "192.0.2.7");
  EXPECT_EQ(service::canonical_ip("::FFFF:127.0.0.1"), "127.0.0.1");
  for (const char* unchanged : {"192.0.2.7", "::1", "fd00::2", "", "not an address"}) {
    EXPECT_EQ(service::canonical_ip(unchanged), unchanged);
  }
  for (const char* loopback : {"127.0.0.1", "127.3.2.1", "::1", "::ffff:127.0.0.1"}) {
    EXPECT_TRUE(service::is_loopback_ip(loopback)) << loopback;
  }
  for (const char* other : {"192.0.2.7", "::ffff:192.0.2.7", "::", "0.0.0.0", "fd00::2", "", "localhost"}) {
    EXPECT_FALSE(service::is_loopback_ip(other)) << other;
  }
}

// Both frontends on the same table: the same header is let in or refused
// alike, with the same message (headers the transports refuse themselves,
// such as 10 kB, are refused, never let in).
TEST_F(ExposedServer, BothFrontendsReadTheAuthorizationHeaderAlike) {
  const auto server = test::ServerProcess({"--auth-token", kToken});
  Caller local("127.0.0.1", server);
  // Tokens one byte off the right one, at its first, middle and last byte,
  // and one byte short or long: a comparison that stops early or checks a
  // prefix lets one of them in.
  const std::string token(kToken);
  auto one_byte_off = [&](size_t at) {
    std::string off = token;
    off[at] = off[at] == 'x' ? 'y' : 'x';
    return "Bearer " + off;
  };
  const std::vector<std::vector<std::string>> table = {
      {one_byte_off(0)},
      {one_byte_off(token.size() / 2)},
      {one_byte_off(token.size() - 1)},
      {"Bearer " + token.substr(0, token.size() - 1)},
      {"Bearer " + token + "x"},
      {},
      {""},
      {"Bearer"},
      {"Basic dXNlcjpwYXNz"},
      {std::string("Bearer ") + kToken},
      {std::string("bearer ") + kToken},
      {std::string("BEARER ") + kToken},
      {std::string("Bearer    ") + kToken + "   "},
      {"Bearer wrong"},
      {std::string("Bearer ") + kToken + " extra"},
      {std::string("Bearer ") + kToken, std::string("Bearer ") + kToken},
      {"Bearer " + std::string(10 * 1024, 'a')},
  };
  for (const auto& headers : table) {
    const std::string shown = headers.empty() ? "(none)" : headers.front().substr(0, 40) + " x" +
                                                               std::to_string(headers.size());
    httplib::Headers rest_headers;
    for (const auto& value : headers) rest_headers.emplace("Authorization", value);
    const auto reply = local.post("/v1/models/h36m-dkgm-h100:activate", "{}", rest_headers);

    grpc::ClientContext context;
    for (const auto& value : headers) context.AddMetadata("authorization", value);
    v1::ActivateModelRequest request;
    request.set_model("h36m-dkgm-h100");
    v1::ModelInfo info;
    const auto status = local.stub->ActivateModel(&context, request, &info);

    const bool expected_in = parse_authorization(headers).token == kToken;
    EXPECT_EQ(reply.status == 200, expected_in) << shown << ": " << reply.status << " " << reply.body;
    EXPECT_EQ(status.ok(), expected_in) << shown << ": " << status.error_message();
    if (reply.status == 401 && status.error_code() == grpc::StatusCode::UNAUTHENTICATED) {
      EXPECT_EQ("authorization: " + reply.error().at("message").get<std::string>(), status.error_message()) << shown;
    }
  }
}

}  // namespace
}  // namespace mm
