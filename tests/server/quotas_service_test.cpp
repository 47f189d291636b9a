// Quotas through the real server, over both protocols: an upload over
// --max-upload-bytes, or one that would take the data root past
// --max-data-root-bytes or --max-data-root-files, is refused (413) naming the
// quota, the current use and the option, and writes nothing; a job of more
// iterations than --max-job-iterations is refused (413) naming it; a caller
// with --max-queued-jobs-per-caller queued jobs is refused (429) naming it,
// per token with a token and per IP address without one, and another caller
// still gets in; a job past --max-job-seconds is stopped with its checkpoint
// and fails naming the limit.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"
#include "tests/server/grpc_calls.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm {
namespace {

namespace fs = std::filesystem;
namespace v1 = ::motionmanifold::v1;
using json = nlohmann::json;

const char* const kToken = "quota-token";

// The first `rows` rows of S5 walking: a valid H3.6M text file.
std::string walking_rows(int rows) {
  std::ifstream in(test::h36m_dataset_dir() / "S5" / "walking_1.txt");
  std::string text, line;
  for (int i = 0; i < rows && std::getline(in, line); ++i) text += line + "\n";
  return text;
}

// A data root of one text file, and a small H3.6M tree to train on.
fs::path make_data_root(const fs::path& root) {
  fs::create_directories(root / "operator");
  std::ofstream(root / "operator" / "walking.txt", std::ios::binary) << walking_rows(400);
  for (const auto& [subject, file] : {std::pair{"S1", "posing_2.txt"}, std::pair{"S5", "greeting_1.txt"}}) {
    fs::create_directories(root / "small" / subject);
    fs::create_symlink(test::h36m_dataset_dir() / subject / file, root / "small" / subject / file);
  }
  return root;
}

struct Refusal {
  int http_status = 0;
  grpc::StatusCode grpc_code = grpc::StatusCode::OK;
  std::string field;
};

// The REST reply's and the gRPC status's refusal, each expected to say `words`.
void expect_refused(const test::Reply& rest, const grpc::Status& status, const grpc::ClientContext& context,
                    const Refusal& expected, const std::vector<std::string>& words) {
  EXPECT_EQ(rest.status, expected.http_status) << rest.body;
  EXPECT_EQ(status.error_code(), expected.grpc_code) << status.error_message();
  if (rest.document.is_object() && rest.document.contains("error")) {
    EXPECT_EQ(rest.field(), expected.field) << rest.body;
    for (const auto& word : words) {
      EXPECT_NE(rest.error()["message"].get<std::string>().find(word), std::string::npos)
          << "\"" << word << "\" not in " << rest.body;
    }
  } else {
    ADD_FAILURE() << "not a JSON error: " << rest.body;
  }
  // No field at fault: no trailing field either.
  EXPECT_EQ(test::grpc_error_field(context), expected.field.empty() ? "(none)" : expected.field);
  for (const auto& word : words) {
    EXPECT_NE(status.error_message().find(word), std::string::npos) << "\"" << word << "\" not in " << status.error_message();
  }
}

test::Reply upload_rest(const test::ServerProcess& server, const std::string& path, const std::string& content) {
  return test::post(server.rest_port(), "/v1/clips:upload?path=" + path, content, test::bearer(kToken),
                    "application/octet-stream");
}

grpc::Status upload_grpc(v1::MotionManifold::Stub& stub, grpc::ClientContext& context, const std::string& path,
                         const std::string& content) {
  v1::UploadClipRequest request;
  request.set_path(path);
  request.set_content(content);
  v1::ClipFile clip;
  return stub.UploadClip(&context, request, &clip);
}

// Bytes and files under the root, as the server counts them (its upload
// marks left out).
std::pair<int64_t, int64_t> root_use(const fs::path& root) {
  int64_t bytes = 0, files = 0;
  for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it) {
    if (it->path().filename() == ".uploads") {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_symlink() || !it->is_regular_file()) continue;
    ++files;
    bytes += static_cast<int64_t>(it->file_size());
  }
  return {bytes, files};
}

TEST(Quotas, UploadsOverTheFileSizeOrTheDataRootsQuotaAreRefusedNamingItAndWriteNothing) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = make_data_root(scratch.path() / "data");
  const std::string file = walking_rows(400);
  const auto [bytes, files] = root_use(root);
  // Room for one more file of this size, not two; and for a file a little
  // larger than it, not twice as large.
  const int64_t max_root = bytes + file.size() + file.size() / 2;
  test::ServerProcess server({"--data-root", root.string(), "--auth-token", kToken, "--max-upload-bytes",
                              std::to_string(file.size() + 100), "--max-data-root-bytes", std::to_string(max_root)});
  auto stub = test::grpc_stub(server.grpc_target());

  // A file over --max-upload-bytes, over both protocols.
  const std::string large = walking_rows(800);
  {
    auto context = test::grpc_context(kToken);
    const auto status = upload_grpc(*stub, *context, "mine/large.txt", large);
    expect_refused(upload_rest(server, "mine/large.txt", large), status, *context,
                   {413, grpc::StatusCode::RESOURCE_EXHAUSTED, "content"},
                   {"--max-upload-bytes", std::to_string(large.size()), std::to_string(file.size() + 100)});
  }
  EXPECT_FALSE(fs::exists(root / "mine" / "large.txt"));

  // The first upload fits; the second would take the root past its quota.
  const test::Reply first = upload_rest(server, "mine/first.txt", file);
  ASSERT_EQ(first.status, 200) << first.body;
  const int64_t use = bytes + static_cast<int64_t>(file.size());
  EXPECT_EQ(root_use(root).first, use);
  {
    auto context = test::grpc_context(kToken);
    const auto status = upload_grpc(*stub, *context, "mine/second.txt", file);
    expect_refused(upload_rest(server, "mine/second.txt", file), status, *context,
                   {413, grpc::StatusCode::RESOURCE_EXHAUSTED, "content"},
                   {"--max-data-root-bytes", "holds " + std::to_string(use) + " bytes", std::to_string(max_root)});
  }
  EXPECT_FALSE(fs::exists(root / "mine" / "second.txt"));
  EXPECT_EQ(root_use(root).first, use);
  EXPECT_EQ(server.terminate(), 0) << server.log();

  // Counted in files: the root holds files + 1 now, and takes none more.
  const int64_t held = files + 1;
  test::ServerProcess full({"--data-root", root.string(), "--auth-token", kToken, "--max-data-root-files",
                            std::to_string(held)});
  auto full_stub = test::grpc_stub(full.grpc_target());
  const std::string tiny = walking_rows(2);
  auto context = test::grpc_context(kToken);
  const auto status = upload_grpc(*full_stub, *context, "mine/tiny.txt", tiny);
  expect_refused(upload_rest(full, "mine/tiny.txt", tiny), status, *context,
                 {413, grpc::StatusCode::RESOURCE_EXHAUSTED, "content"},
                 {"--max-data-root-files", "holds " + std::to_string(held) + " files"});
  EXPECT_FALSE(fs::exists(root / "mine" / "tiny.txt"));
}

json tiny_job(int64_t iterations) {
  return {{"dataset", "small"}, {"variant", "D"}, {"iterations", iterations}, {"hidden", 16}, {"batch", 4}};
}

v1::JobSpec tiny_job_proto(int64_t iterations) {
  v1::JobSpec spec;
  spec.set_dataset("small");
  spec.set_variant("D");
  spec.set_iterations(iterations);
  spec.set_hidden(16);
  spec.set_batch(4);
  return spec;
}

grpc::Status submit_grpc(v1::MotionManifold::Stub& stub, grpc::ClientContext& context, const v1::JobSpec& spec) {
  v1::SubmitJobRequest request;
  *request.mutable_spec() = spec;
  v1::Job job;
  return stub.SubmitJob(&context, request, &job);
}

json wait_for_job(int port, const std::string& id, const std::function<bool(const json&)>& done, int seconds = 300) {
  json job;
  for (int i = 0; i < seconds * 5; ++i) {
    job = test::rest_call(port, kToken, "GET", "/v1/jobs/" + id);
    if (done(job)) return job;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ADD_FAILURE() << "job " << id << " timed out: " << job.dump();
  return job;
}

TEST(Quotas, JobsOfTooManyIterationsOrBeyondTheTokensQueueAreRefusedNamingTheOption) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = make_data_root(scratch.path() / "data");
  test::ServerProcess server({"--data-root", root.string(), "--state-dir", (scratch.path() / "state").string(),
                              "--auth-token", kToken, "--max-job-iterations", "500",
                              "--max-queued-jobs-per-caller", "1"});
  auto stub = test::grpc_stub(server.grpc_target());
  const int port = server.rest_port();

  // Iterations, the spec's own or the variant's default (60,000 for D).
  for (const int64_t iterations : {501, 0}) {
    auto context = test::grpc_context(kToken);
    const auto status = submit_grpc(*stub, *context, tiny_job_proto(iterations));
    const test::Reply rest = test::post(port, "/v1/jobs", tiny_job(iterations), test::bearer(kToken));
    expect_refused(rest, status, *context, {413, grpc::StatusCode::RESOURCE_EXHAUSTED, "iterations"},
                   {"--max-job-iterations", "500", iterations == 0 ? "60000" : "501"});
  }
  EXPECT_EQ(test::rest_call(port, kToken, "GET", "/v1/jobs")["jobs"].size(), 0u);

  // One job runs, one is queued: the token's queue is full.
  const std::string running = test::rest_call(port, kToken, "POST", "/v1/jobs", tiny_job(500))["id"];
  wait_for_job(port, running, [](const json& job) { return job["state"] != "queued"; });
  const std::string queued = test::rest_call(port, kToken, "POST", "/v1/jobs", tiny_job(500))["id"];
  {
    auto context = test::grpc_context(kToken);
    const auto status = submit_grpc(*stub, *context, tiny_job_proto(500));
    const test::Reply rest = test::post(port, "/v1/jobs", tiny_job(500), test::bearer(kToken));
    expect_refused(rest, status, *context, {429, grpc::StatusCode::RESOURCE_EXHAUSTED, ""},
                   {"--max-queued-jobs-per-caller", "1 queued jobs of the holders of the server's token"});
  }
  EXPECT_EQ(test::rest_call(port, kToken, "GET", "/v1/jobs")["jobs"].size(), 2u);
  // Room again once the queued job is gone.
  test::rest_call(port, kToken, "POST", "/v1/jobs/" + queued + ":cancel");
  const std::string next = test::rest_call(port, kToken, "POST", "/v1/jobs", tiny_job(500))["id"];
  for (const auto& id : {running, next}) test::rest_call(port, kToken, "POST", "/v1/jobs/" + id + ":cancel");
}

// A REST call from the loopback address `source` (127.0.0.2, ...): another
// caller on this machine, as the server tells callers apart without a token.
test::Reply post_from(const std::string& source, int port, const std::string& path, const std::string& body) {
  test::Reply reply;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in local{}, remote{};
  local.sin_family = remote.sin_family = AF_INET;
  inet_pton(AF_INET, source.c_str(), &local.sin_addr);
  inet_pton(AF_INET, "127.0.0.1", &remote.sin_addr);
  remote.sin_port = htons(static_cast<uint16_t>(port));
  if (bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0 ||
      connect(fd, reinterpret_cast<sockaddr*>(&remote), sizeof remote) != 0) {
    ADD_FAILURE() << "cannot connect from " << source;
    close(fd);
    return reply;
  }
  const std::string request = "POST " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n"
                              "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) +
                              "\r\n\r\n" + body;
  if (write(fd, request.data(), request.size()) != static_cast<ssize_t>(request.size())) ADD_FAILURE() << "write";
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = read(fd, buffer, sizeof buffer)) > 0;) answer.append(buffer, static_cast<size_t>(n));
  close(fd);
  reply.status = answer.size() > 12 ? std::stoi(answer.substr(9, 3)) : 0;
  const auto body_start = answer.find("\r\n\r\n");
  reply.body = body_start == std::string::npos ? "" : answer.substr(body_start + 4);
  reply.document = json::parse(reply.body, nullptr, false);
  if (reply.document.is_discarded()) reply.document = nullptr;
  return reply;
}

TEST(Quotas, WithoutATokenTheQueueIsBoundedPerCallerAddress) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = make_data_root(scratch.path() / "data");
  test::ServerProcess server({"--data-root", root.string(), "--state-dir", (scratch.path() / "state").string(),
                              "--max-queued-jobs-per-caller", "1"});
  const int port = server.rest_port();
  const std::string spec = tiny_job(500).dump();
  const test::Reply running = post_from("127.0.0.1", port, "/v1/jobs", spec);
  ASSERT_EQ(running.status, 200) << running.body;
  wait_for_job(port, running.document["id"], [](const json& job) { return job["state"] != "queued"; });
  const test::Reply queued = post_from("127.0.0.1", port, "/v1/jobs", spec);
  ASSERT_EQ(queued.status, 200) << queued.body;
  const test::Reply refused = post_from("127.0.0.1", port, "/v1/jobs", spec);
  EXPECT_EQ(refused.status, 429) << refused.body;
  EXPECT_NE(refused.body.find("1 queued jobs of 127.0.0.1"), std::string::npos) << refused.body;
  EXPECT_NE(refused.body.find("--max-queued-jobs-per-caller"), std::string::npos) << refused.body;
  // Another address of this machine has a queue of its own.
  const test::Reply other = post_from("127.0.0.2", port, "/v1/jobs", spec);
  EXPECT_EQ(other.status, 200) << other.body;
  for (const test::Reply* job : {&running, &queued, &other}) {
    if (!job->document.is_object()) continue;
    EXPECT_EQ(post_from("127.0.0.1", port, "/v1/jobs/" + job->document["id"].get<std::string>() + ":cancel", "{}").status,
              200);
  }
}

TEST(Quotas, AJobPastItsWallTimeIsStoppedWithItsCheckpointAndFailsNamingTheLimit) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = make_data_root(scratch.path() / "data");
  // A prepared dataset, so that the job's only child is the training run.
  const auto prepared = test::run_command(MM_TOOL_PATH, "prepare --data " + (root / "small").string() + " --out " +
                                                            (root / "small.mmd").string() + " --train S1 --test S5");
  ASSERT_EQ(prepared.exit_code, 0) << prepared.err;
  const fs::path state = scratch.path() / "state";
  test::ServerProcess server({"--data-root", root.string(), "--state-dir", state.string(), "--auth-token", kToken,
                              "--max-job-seconds", "20", "--checkpoint-every", "1000000"});
  const int port = server.rest_port();
  json spec = tiny_job(1000000);
  spec["dataset"] = "small.mmd";
  const std::string id = test::rest_call(port, kToken, "POST", "/v1/jobs", spec)["id"];
  const json job = wait_for_job(port, id, [](const json& j) {
    return j["state"] == "succeeded" || j["state"] == "failed" || j["state"] == "cancelled";
  });
  EXPECT_EQ(job["state"], "failed") << job.dump();
  const std::string error = job.value("error", "");
  EXPECT_NE(error.find("--max-job-seconds"), std::string::npos) << error;
  EXPECT_NE(error.find("longer than 20 s"), std::string::npos) << error;
  EXPECT_LT(job["progress"].value("iteration", 0), 1000000);
  // Stopped as a cancel stops it: a run that got to training wrote its
  // checkpoint on the way out (the cadence above never would).
  if (job["progress"].value("iteration", 0) > 0) {
    EXPECT_TRUE(fs::exists(state / "jobs" / id / "run" / "checkpoint.pt")) << error;
  } else {
    ADD_FAILURE() << "the run never reached its first iteration in 20 s; the machine is too busy for this test: "
                  << error;
  }
}

}  // namespace
}  // namespace mm
