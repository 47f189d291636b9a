// Training through the service, end to end over REST: a job on a small real
// dataset is submitted, survives the server being SIGKILLed mid-run (it
// resumes from its checkpoint when the server comes back), publishes a model
// equal to that of an uninterrupted run, and the model is activated and
// answers. SIGTERM during a job checkpoints it and exits 0.
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "tests/common/test_environment.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* const kToken = "job-token";

// A data root holding a small H3.6M text tree (links to a few real files):
// training subject S1, test subject S5.
fs::path small_data_root(const fs::path& scratch) {
  const fs::path root = scratch / "data";
  for (const auto& [subject, files] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"S1", {"walking_1.txt", "walking_2.txt", "eating_1.txt"}}, {"S5", {"walking_1.txt"}}}) {
    fs::create_directories(root / "small" / subject);
    for (const auto& file : files) fs::create_symlink(h36m_dataset_dir() / subject / file, root / "small" / subject / file);
  }
  return root;
}

class Service {
 public:
  explicit Service(const ServerProcess& server) : server_(server) {}
  json call(const std::string& method, const std::string& path, const json& body = json(), int expected = 200) {
    return test::rest_call(server_.rest_port(), kToken, method, path, body, expected);
  }
  // Polls the job until `done(job)` or the timeout; returns the last record.
  json wait_for(const std::string& id, const std::function<bool(const json&)>& done, int seconds = 300) {
    json job;
    for (int i = 0; i < seconds * 5; ++i) {
      job = call("GET", "/v1/jobs/" + id);
      if (done(job)) return job;
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    ADD_FAILURE() << "job " << id << " timed out: " << job.dump();
    return job;
  }

 private:
  const ServerProcess& server_;
};

json small_job(const std::string& model_name) {
  return {{"dataset", "small"}, {"variant", "D"}, {"iterations", 200}, {"hidden", 16},
          {"batch", 4},         {"seed", 5},      {"model_name", model_name}};
}

std::string file_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

bool finished(const json& job) {
  const auto state = job.value("state", "");
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

TEST(ServiceJobs, AJobSurvivesAKilledServerAndPublishesTheUninterruptedModel) {
  MM_REQUIRE_H36M();
  const fs::path scratch = fs::temp_directory_path() / ("mm-service-jobs-" + std::to_string(getpid()));
  fs::create_directories(scratch);
  const auto data_root = small_data_root(scratch);
  ServerProcess server({"--state-dir", (scratch / "state").string(), "--data-root", data_root.string(),
                        "--checkpoint-every", "5", "--auth-token", kToken});
  Service service(server);

  // Uninterrupted, for reference.
  const auto reference = service.call("POST", "/v1/jobs", small_job("small-reference"));
  const auto reference_done = service.wait_for(reference["id"], finished);
  ASSERT_EQ(reference_done["state"], "succeeded") << reference_done.dump();

  // The same job, with the server killed once it has checkpointed.
  const auto job = service.call("POST", "/v1/jobs", small_job("small-resumed"));
  const std::string id = job["id"];
  // What was sent is what runs: the spec and the configuration it resolved
  // to both carry the request's batch, hidden size, iterations and seed.
  for (const auto& [field, value] : std::vector<std::pair<std::string, int>>{
           {"batch", 4}, {"iterations", 200}, {"seed", 5}}) {
    EXPECT_EQ(job["spec"][field], value) << field << " in " << job.dump();
    EXPECT_EQ(job["resolved_config"][field], value) << field << " in " << job.dump();
  }
  EXPECT_EQ(job["spec"]["hidden"], 16) << job.dump();
  EXPECT_EQ(job["resolved_config"]["model"]["hidden"], 16) << job.dump();
  const auto running = service.wait_for(id, [](const json& j) { return j["progress"].value("iteration", 0) >= 12; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  server.kill();
  server.restart();
  Service again(server);
  const auto done = again.wait_for(id, finished);
  ASSERT_EQ(done["state"], "succeeded") << done.dump();
  EXPECT_EQ(done["resumes"], 1);
  EXPECT_EQ(done["progress"]["iteration"], 200);
  EXPECT_EQ(done["published_model"], "small-resumed");
  for (const char* file : {"encoder.pt", "velocity_decoder.pt"}) {
    EXPECT_EQ(file_bytes(fs::path(server.model_store()) / "small-resumed" / file),
              file_bytes(fs::path(server.model_store()) / "small-reference" / file))
        << file << " differs from the uninterrupted run's";
  }

  // The published model is served once activated.
  const auto activated = again.call("POST", "/v1/models/small-resumed:activate");
  EXPECT_TRUE(activated.value("active", false)) << activated.dump();
  const auto sample = again.call("POST", "/v1/sample", {{"count", 1}, {"seed", 2}});
  EXPECT_EQ(sample["answered_by"]["model"], "small-resumed");
  EXPECT_EQ(sample["motions"][0]["frames"], 150);
  fs::remove_all(scratch);
}

TEST(ServiceJobs, SigtermCheckpointsTheRunningJobExitsZeroAndTheJobResumes) {
  MM_REQUIRE_H36M();
  const fs::path scratch = fs::temp_directory_path() / ("mm-service-term-" + std::to_string(getpid()));
  fs::create_directories(scratch);
  const auto data_root = small_data_root(scratch);
  ServerProcess server({"--state-dir", (scratch / "state").string(), "--data-root", data_root.string(),
                        "--checkpoint-every", "1000", "--auth-token", kToken});
  Service service(server);
  auto spec = small_job("small-term");
  spec["iterations"] = 2000;
  const std::string id = service.call("POST", "/v1/jobs", spec)["id"];
  service.wait_for(id, [](const json& j) { return j["progress"].value("iteration", 0) >= 3; });
  EXPECT_EQ(server.terminate(), 0) << server.log();
  // The job was checkpointed at SIGTERM (not at the every-1000 cadence) and
  // stays queued for the next start.
  server.restart();
  Service again(server);
  const auto resumed = again.wait_for(id, [](const json& j) { return j.value("resumes", 0) >= 1 || finished(j); });
  EXPECT_EQ(resumed["resumes"], 1) << resumed.dump();
  EXPECT_GE(resumed["progress"].value("iteration", 0), 3) << "the resumed run started over";
  again.call("POST", "/v1/jobs/" + id + ":cancel");
  fs::remove_all(scratch);
}

}  // namespace
}  // namespace mm::test
