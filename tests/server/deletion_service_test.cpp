// Deletion through the real server, over both protocols, behind the token:
// a model leaves the listing and its folder the store (a linked one loses
// its link, not what it points to), and is no longer answered by name; the
// active model and the default one are refused. A finished job's record
// and folder go, and stay gone after a restart; a running one is refused
// until cancelled. An uploaded clip goes; the operator's files, paths
// outside the root and missing files are refused naming the path. Every
// delete without the token, or with a wrong one, is refused and removes
// nothing.
#include <gtest/gtest.h>

#include <algorithm>
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

const char* const kToken = "delete-token";

// Without the token and with a wrong one, over both protocols: 401 and
// UNAUTHENTICATED naming "authorization".
void expect_token_needed(const std::string& rest_path,
                         const std::function<grpc::Status(grpc::ClientContext&)>& grpc_call, int port) {
  for (const std::string token : {"", "wrong"}) {
    const test::Reply rest = test::del(port, rest_path, token.empty() ? httplib::Headers{} : test::bearer(token));
    EXPECT_EQ(rest.status, 401) << rest_path << " with \"" << token << "\": " << rest.body;
    auto context = test::grpc_context(token);
    const grpc::Status status = grpc_call(*context);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << status.error_message();
    EXPECT_EQ(test::grpc_error_field(*context), "authorization");
  }
}

std::vector<std::string> model_names(int port) {
  std::vector<std::string> names;
  for (const auto& model : test::get(port, "/v1/models").document["models"]) names.push_back(model["name"]);
  return names;
}

bool contains(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

TEST(Deletion, AModelLeavesTheStoreOverEitherProtocolButNeverTheActiveOrDefaultOne) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  test::ServerProcess server({"--auth-token", kToken});
  const fs::path store = server.model_store();
  const fs::path shipped = fs::path(MM_SOURCE_DIR) / "models" / "h36m-dkgm-cpu";
  for (const char* name : {"doomed-rest", "doomed-grpc"}) fs::copy(shipped, store / name, fs::copy_options::recursive);
  // A model linked into the store from elsewhere.
  fs::copy(shipped, scratch.path() / "kept", fs::copy_options::recursive);
  fs::create_directory_symlink(scratch.path() / "kept", store / "linked");
  const int port = server.rest_port();
  auto stub = test::grpc_stub(server.grpc_target());
  const auto delete_grpc = [&](grpc::ClientContext& context, const std::string& name) {
    v1::DeleteModelRequest request;
    request.set_model(name);
    v1::ModelInfo info;
    return stub->DeleteModel(&context, request, &info);
  };

  expect_token_needed("/v1/models/doomed-rest",
                      [&](grpc::ClientContext& context) { return delete_grpc(context, "doomed-grpc"); }, port);
  EXPECT_TRUE(fs::exists(store / "doomed-rest" / "manifest.json"));
  EXPECT_TRUE(fs::exists(store / "doomed-grpc" / "manifest.json"));

  // Loaded (a call names it), then deleted: no longer listed, described or answered.
  ASSERT_EQ(test::post(port, "/v1/sample", json{{"model", "doomed-rest"}, {"count", 1}}).status, 200);
  const test::Reply deleted = test::del(port, "/v1/models/doomed-rest", test::bearer(kToken));
  ASSERT_EQ(deleted.status, 200) << deleted.body;
  EXPECT_EQ(deleted.document["name"], "doomed-rest");
  EXPECT_EQ(deleted.document["loaded"], true);
  EXPECT_FALSE(fs::exists(store / "doomed-rest"));
  EXPECT_FALSE(contains(model_names(port), "doomed-rest"));
  EXPECT_EQ(test::get(port, "/v1/models/doomed-rest").status, 404);
  EXPECT_EQ(test::post(port, "/v1/sample", json{{"model", "doomed-rest"}, {"count", 1}}).status, 404);
  {
    auto context = test::grpc_context(kToken);
    const auto status = delete_grpc(*context, "doomed-grpc");
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  EXPECT_FALSE(fs::exists(store / "doomed-grpc"));
  EXPECT_FALSE(contains(model_names(port), "doomed-grpc"));
  // A linked model loses its link only.
  ASSERT_EQ(test::del(port, "/v1/models/linked", test::bearer(kToken)).status, 200);
  EXPECT_FALSE(fs::exists(fs::symlink_status(store / "linked")));
  EXPECT_TRUE(fs::exists(scratch.path() / "kept" / "manifest.json"));
  // Nothing of the deleted models is left in the store, hidden or not.
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(store)) left.push_back(entry.path().filename().string());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{"h36m-dkgm-cpu", "h36m-dkgm-h100"}));

  // The active model, and the default one once another is active.
  ASSERT_EQ(test::post(port, "/v1/models/h36m-dkgm-cpu:activate", std::string(), test::bearer(kToken)).status, 200);
  for (const char* name : {"h36m-dkgm-cpu", "h36m-dkgm-h100"}) {
    const test::Reply rest = test::del(port, std::string("/v1/models/") + name, test::bearer(kToken));
    EXPECT_EQ(rest.status, 409) << rest.body;
    EXPECT_EQ(rest.field(), "model") << rest.body;
    auto context = test::grpc_context(kToken);
    const auto status = delete_grpc(*context, name);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
    EXPECT_NE(status.error_message().find(name == std::string("h36m-dkgm-cpu") ? "active model" : "--default-model"),
              std::string::npos)
        << status.error_message();
    EXPECT_TRUE(fs::exists(store / name / "manifest.json")) << name;
  }
  EXPECT_EQ(test::del(port, "/v1/models/no-such-model", test::bearer(kToken)).status, 404);
}

// A data root holding a small H3.6M text tree: training subject S1, test subject S5.
fs::path small_data_root(const fs::path& scratch) {
  const fs::path root = scratch / "data";
  for (const auto& [subject, file] : {std::pair{"S1", "posing_2.txt"}, std::pair{"S5", "greeting_1.txt"}}) {
    fs::create_directories(root / "small" / subject);
    fs::create_symlink(test::h36m_dataset_dir() / subject / file, root / "small" / subject / file);
  }
  return root;
}

json wait_for_job(int port, const std::string& id, const std::function<bool(const json&)>& done) {
  json job;
  for (int i = 0; i < 300 * 5; ++i) {
    job = test::rest_call(port, kToken, "GET", "/v1/jobs/" + id);
    if (done(job)) return job;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ADD_FAILURE() << "job " << id << " timed out: " << job.dump();
  return job;
}

bool finished(const json& job) {
  const std::string state = job.value("state", "");
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

TEST(Deletion, AFinishedJobGoesWithItsFolderForGoodAndARunningOneIsRefused) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path state = scratch.path() / "state";
  test::ServerProcess server({"--data-root", small_data_root(scratch.path()).string(), "--state-dir", state.string(),
                              "--auth-token", kToken});
  auto stub = test::grpc_stub(server.grpc_target());
  const auto delete_grpc = [&](grpc::ClientContext& context, const std::string& id) {
    v1::DeleteJobRequest request;
    request.set_id(id);
    v1::Job job;
    return stub->DeleteJob(&context, request, &job);
  };
  const json spec = {{"dataset", "small"}, {"variant", "D"}, {"hidden", 16}, {"batch", 4}, {"model_name", "kept"}};
  const auto submit = [&](int64_t iterations, const std::string& model) {
    json with = spec;
    with["iterations"] = iterations;
    with["model_name"] = model;
    return test::rest_call(server.rest_port(), kToken, "POST", "/v1/jobs", with)["id"].get<std::string>();
  };
  const std::string done = submit(20, "kept");
  ASSERT_EQ(wait_for_job(server.rest_port(), done, finished)["state"], "succeeded");
  const std::string running = submit(1000000, "never");
  wait_for_job(server.rest_port(), running, [](const json& job) { return job["state"] == "running"; });
  ASSERT_TRUE(fs::is_directory(state / "jobs" / done));

  // A running job: cancel it first.
  {
    const test::Reply rest = test::del(server.rest_port(), "/v1/jobs/" + running, test::bearer(kToken));
    EXPECT_EQ(rest.status, 409) << rest.body;
    EXPECT_NE(rest.body.find("cancel it first"), std::string::npos) << rest.body;
    auto context = test::grpc_context(kToken);
    const auto status = delete_grpc(*context, running);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
    EXPECT_EQ(test::grpc_error_field(*context), "id");
  }
  expect_token_needed("/v1/jobs/" + done, [&](grpc::ClientContext& context) { return delete_grpc(context, done); },
                      server.rest_port());
  EXPECT_TRUE(fs::is_directory(state / "jobs" / done));

  // Finished: the record and the folder go; the model it published stays.
  const test::Reply deleted = test::del(server.rest_port(), "/v1/jobs/" + done, test::bearer(kToken));
  ASSERT_EQ(deleted.status, 200) << deleted.body;
  EXPECT_EQ(deleted.document["id"], done);
  EXPECT_EQ(deleted.document["state"], "succeeded");
  EXPECT_FALSE(fs::exists(state / "jobs" / done));
  EXPECT_EQ(test::get(server.rest_port(), "/v1/jobs/" + done).status, 404);
  EXPECT_TRUE(fs::exists(fs::path(server.model_store()) / "kept" / "manifest.json"));
  // Cancelled, then deleted over gRPC once its run has stopped.
  test::rest_call(server.rest_port(), kToken, "POST", "/v1/jobs/" + running + ":cancel");
  grpc::Status status;
  for (int attempt = 0; attempt < 600; ++attempt) {
    auto context = test::grpc_context(kToken);
    status = delete_grpc(*context, running);
    if (status.error_code() != grpc::StatusCode::FAILED_PRECONDITION) break;
    EXPECT_NE(status.error_message().find("still stopping"), std::string::npos) << status.error_message();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ASSERT_TRUE(status.ok()) << status.error_message();
  EXPECT_FALSE(fs::exists(state / "jobs" / running));
  std::vector<std::string> left;
  for (const auto& entry : fs::directory_iterator(state / "jobs")) left.push_back(entry.path().filename().string());
  EXPECT_TRUE(left.empty()) << left.front();

  // Gone for good: a restarted server reads no record of either.
  EXPECT_EQ(server.terminate(), 0) << server.log();
  server.restart();
  EXPECT_EQ(test::rest_call(server.rest_port(), kToken, "GET", "/v1/jobs")["jobs"].size(), 0u);
  for (const auto& id : {done, running}) EXPECT_EQ(test::get(server.rest_port(), "/v1/jobs/" + id).status, 404);
}

TEST(Deletion, AnUploadedClipGoesButTheOperatorsFilesAndPathsOutsideTheRootAreRefused) {
  MM_REQUIRE_H36M();
  test::ScratchDir scratch;
  const fs::path root = scratch.path() / "data";
  fs::create_directories(root / "operator");
  fs::copy_file(test::h36m_dataset_dir() / "S5" / "walking_1.txt", root / "operator" / "walking.txt");
  std::ofstream(scratch.path() / "outside.txt") << "0\n";
  test::ServerProcess server({"--data-root", root.string(), "--auth-token", kToken});
  const int port = server.rest_port();
  auto stub = test::grpc_stub(server.grpc_target());
  const auto delete_grpc = [&](grpc::ClientContext& context, const std::string& path) {
    v1::DeleteClipRequest request;
    request.set_path(path);
    v1::ClipFile clip;
    return stub->DeleteClip(&context, request, &clip);
  };
  const std::string text = test::read_text((root / "operator" / "walking.txt").string());
  for (const char* name : {"mine/a.txt", "mine/b.txt"}) {
    const test::Reply uploaded = test::post(port, std::string("/v1/clips:upload?path=") + name, text,
                                            test::bearer(kToken), "application/octet-stream");
    ASSERT_EQ(uploaded.status, 200) << uploaded.body;
  }

  // The listing says which files are uploads.
  const test::Reply before = test::get(port, "/v1/clips", test::bearer(kToken));
  ASSERT_EQ(before.document["clips"].size(), 3u) << before.body;
  for (const auto& clip : before.document["clips"]) {
    EXPECT_EQ(clip["uploaded"], clip["path"] != "operator/walking.txt") << clip.dump();
  }
  expect_token_needed("/v1/clips?path=mine/a.txt",
                      [&](grpc::ClientContext& context) { return delete_grpc(context, "mine/b.txt"); }, port);
  EXPECT_TRUE(fs::exists(root / "mine" / "a.txt"));
  EXPECT_TRUE(fs::exists(root / "mine" / "b.txt"));

  const test::Reply deleted = test::del(port, "/v1/clips?path=mine/a.txt", test::bearer(kToken));
  ASSERT_EQ(deleted.status, 200) << deleted.body;
  EXPECT_EQ(deleted.document, (json{{"path", "mine/a.txt"}, {"format", "h36m-text"}, {"size_bytes", text.size()}, {"uploaded", true}}));
  {
    auto context = test::grpc_context(kToken);
    const auto status = delete_grpc(*context, "mine/b.txt");
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  for (const char* name : {"a.txt", "b.txt"}) EXPECT_FALSE(fs::exists(root / "mine" / name)) << name;
  std::vector<std::string> listed;
  const test::Reply list = test::get(port, "/v1/clips", test::bearer(kToken));
  for (const auto& clip : list.document["clips"]) listed.push_back(clip["path"]);
  EXPECT_EQ(listed, std::vector<std::string>{"operator/walking.txt"}) << list.body;

  // Refused over both protocols, naming the path; nothing removed.
  struct Case {
    std::string path;
    int http_status;
    grpc::StatusCode code;
    std::string words;
  };
  for (const Case& c : std::vector<Case>{
           {"operator/walking.txt", 409, grpc::StatusCode::FAILED_PRECONDITION, "was not uploaded"},
           {"../outside.txt", 400, grpc::StatusCode::INVALID_ARGUMENT, "outside the data root"},
           {(scratch.path() / "outside.txt").string(), 400, grpc::StatusCode::INVALID_ARGUMENT, "outside the data root"},
           {"mine/a.txt", 404, grpc::StatusCode::NOT_FOUND, "names no file"},
           {"mine", 400, grpc::StatusCode::INVALID_ARGUMENT, "not a file"},
           {"", 400, grpc::StatusCode::INVALID_ARGUMENT, "empty"}}) {
    const test::Reply rest = test::del(port, "/v1/clips?path=" + httplib::detail::encode_query_param(c.path),
                                       test::bearer(kToken));
    EXPECT_EQ(rest.status, c.http_status) << c.path << ": " << rest.body;
    EXPECT_NE(rest.body.find(c.words), std::string::npos) << rest.body;
    if (rest.document.is_object()) EXPECT_EQ(rest.field(), "path") << rest.body;
    auto context = test::grpc_context(kToken);
    const auto status = delete_grpc(*context, c.path);
    EXPECT_EQ(status.error_code(), c.code) << c.path << ": " << status.error_message();
    EXPECT_EQ(test::grpc_error_field(*context), "path") << c.path;
  }
  EXPECT_TRUE(fs::exists(root / "operator" / "walking.txt"));
  EXPECT_TRUE(fs::exists(scratch.path() / "outside.txt"));
}

}  // namespace
}  // namespace mm
