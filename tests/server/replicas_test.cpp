// Several replicas of the real server on one PostgreSQL job store (a
// throwaway cluster), one shared state folder and one shared model store:
// submitted jobs run exactly once whichever replica took them, a replica
// SIGKILLed mid-job has its job taken over by the other once the lease
// expires, resumed from its checkpoint into the uninterrupted run's weights,
// and a cancel sent to one replica stops the job running on the other.
#include <gtest/gtest.h>
#include <httplib.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "postgres_cluster.h"
#include "rest_call.h"
#include "server_process.h"
#include "test_environment.h"

namespace mm::test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const char* const kToken = "replica-token";

std::string file_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

int occurrences(const std::string& text, const std::string& what) {
  int count = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
  return count;
}

json call(const ServerProcess& server, const std::string& method, const std::string& path, const json& body = json(),
          int expected = 200) {
  return test::rest_call(server.rest_port(), kToken, method, path, body, expected);
}

bool finished(const json& job) {
  const auto state = job.value("state", "");
  return state == "succeeded" || state == "failed" || state == "cancelled";
}

// Polls the job through `server` until `done(job)` or the timeout.
json wait_for(const ServerProcess& server, const std::string& id, const std::function<bool(const json&)>& done,
              int seconds = 300) {
  json job;
  for (int i = 0; i < seconds * 5; ++i) {
    job = call(server, "GET", "/v1/jobs/" + id);
    if (done(job)) return job;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  ADD_FAILURE() << "job " << id << " timed out: " << job.dump();
  return job;
}

json small_job(const std::string& model_name, int iterations) {
  return {{"dataset", "small"}, {"variant", "D"}, {"iterations", iterations}, {"hidden", 16},
          {"batch", 4},         {"seed", 5},      {"model_name", model_name}};
}

// One database, a state folder, a model store and a small H3.6M text tree
// (links to a few real files: S1 to train, S5 to test), shared by every
// replica the test starts.
class ReplicasTest : public ::testing::Test {
 protected:
  void SetUp() override {
    MM_REQUIRE_H36M();
    shared_ = fs::temp_directory_path() / ("mm-replicas-" + std::to_string(getpid()));
    fs::remove_all(shared_);
    for (const auto& [subject, files] : std::vector<std::pair<std::string, std::vector<std::string>>>{
             {"S1", {"walking_1.txt", "walking_2.txt", "eating_1.txt"}}, {"S5", {"walking_1.txt"}}}) {
      fs::create_directories(shared_ / "data" / "small" / subject);
      for (const auto& file : files) {
        fs::create_symlink(h36m_dataset_dir() / subject / file, shared_ / "data" / "small" / subject / file);
      }
    }
    fs::create_directories(shared_ / "models");
    // A served model, as the server needs one to start.
    for (const char* name : {"h36m-dkgm-h100", "h36m-dkgm-cpu"}) {
      fs::create_directory_symlink(fs::path(MM_SOURCE_DIR) / "models" / name, shared_ / "models" / name);
    }
    cluster_ = std::make_unique<PostgresCluster>();
    uri_ = cluster_->create_database("jobs");
  }
  void TearDown() override {
    replicas_.clear();  // before the database they use
    cluster_.reset();
    if (!shared_.empty()) fs::remove_all(shared_);
  }
  ServerProcess& start_replica() {
    replicas_.push_back(std::make_unique<ServerProcess>(std::vector<std::string>{
        "--job-store", uri_, "--job-lease-seconds", "3", "--state-dir", (shared_ / "state").string(),
        "--data-root", (shared_ / "data").string(), "--model-store", (shared_ / "models").string(),
        "--checkpoint-every", "5", "--auth-token", kToken}));
    return *replicas_.back();
  }
  fs::path job_dir(const std::string& id) const { return shared_ / "state" / "jobs" / id; }
  fs::path model_dir(const std::string& name) const { return shared_ / "models" / name; }

  fs::path shared_;
  std::unique_ptr<PostgresCluster> cluster_;
  std::string uri_;
  std::vector<std::unique_ptr<ServerProcess>> replicas_;
};

TEST_F(ReplicasTest, TenJobsSubmittedToTwoReplicasEachRunExactlyOnce) {
  ServerProcess& a = start_replica();
  ServerProcess& b = start_replica();
  std::vector<std::string> ids;
  for (int i = 0; i < 10; ++i) {
    ids.push_back(call(i % 2 ? b : a, "POST", "/v1/jobs", small_job("tiny-" + std::to_string(i), 12))["id"]);
  }
  EXPECT_EQ(call(a, "GET", "/v1/jobs")["jobs"].size(), 10u) << "one queue, seen by every replica";
  int ran_on_a = 0, ran_on_b = 0;
  for (const auto& id : ids) {
    const json done = wait_for(b, id, finished);
    ASSERT_EQ(done["state"], "succeeded") << done.dump();
    EXPECT_EQ(done["resumes"], 0) << id;
    EXPECT_EQ(done["progress"]["iteration"], 12) << id;
    EXPECT_TRUE(fs::exists(model_dir(done["published_model"]) / "encoder.pt")) << id;
    // One train run in the job's log, one start in the replicas' logs.
    EXPECT_EQ(occurrences(file_text(job_dir(id) / "train.log"), "== train ("), 1) << id;
    const int on_a = occurrences(a.log(), "training job " + id + " started");
    const int on_b = occurrences(b.log(), "training job " + id + " started");
    EXPECT_EQ(on_a + on_b, 1) << id << " started " << on_a << " time(s) on a, " << on_b << " on b";
    ran_on_a += on_a;
    ran_on_b += on_b;
  }
  EXPECT_GT(ran_on_a, 0) << "replica a ran no job";
  EXPECT_GT(ran_on_b, 0) << "replica b ran no job";
}

TEST_F(ReplicasTest, AKilledReplicasJobIsTakenOverFromItsCheckpointAndMatchesAnUninterruptedRun) {
  ServerProcess& a = start_replica();
  // Uninterrupted, for reference.
  const std::string reference = call(a, "POST", "/v1/jobs", small_job("reference", 200))["id"];
  ASSERT_EQ(wait_for(a, reference, finished)["state"], "succeeded");

  // Only replica a is up when the job is claimed, so a runs it.
  const std::string id = call(a, "POST", "/v1/jobs", small_job("taken-over", 200))["id"];
  const json running = wait_for(a, id, [](const json& j) { return j["progress"].value("iteration", 0) >= 12; });
  ASSERT_EQ(running["state"], "running") << running.dump();
  ASSERT_TRUE(fs::exists(job_dir(id) / "run" / "checkpoint.pt"));
  // Killed at once: starting b first took long enough on an idle machine
  // for a to finish the job itself.
  a.kill();
  ServerProcess& b = start_replica();

  const json done = wait_for(b, id, finished);
  ASSERT_EQ(done["state"], "succeeded") << done.dump() << "\n" << b.log();
  EXPECT_EQ(done["resumes"], 1);
  EXPECT_EQ(done["progress"]["iteration"], 200);
  EXPECT_EQ(occurrences(b.log(), "training job " + id + " started"), 1) << b.log();
  EXPECT_EQ(occurrences(file_text(job_dir(id) / "train.log"), "== resume ("), 1);
  for (const char* file : {"encoder.pt", "velocity_decoder.pt"}) {
    const std::string resumed = file_text(model_dir("taken-over") / file);
    EXPECT_FALSE(resumed.empty()) << file;
    EXPECT_TRUE(resumed == file_text(model_dir("reference") / file)) << file << " differs from the uninterrupted run's";
  }
}

TEST_F(ReplicasTest, ACancelSentToOneReplicaStopsTheJobRunningOnAnother) {
  ServerProcess& a = start_replica();
  const std::string id = call(a, "POST", "/v1/jobs", small_job("cancelled", 5000))["id"];
  wait_for(a, id, [](const json& j) { return j["progress"].value("iteration", 0) >= 3; });
  ServerProcess& b = start_replica();
  const json cancelled = call(b, "POST", "/v1/jobs/" + id + ":cancel");
  EXPECT_EQ(cancelled["state"], "cancelled");
  // Replica a sees the record at its next lease renewal (1 s with a 3 s
  // lease) and stops the child; the record stays cancelled.
  bool stopped = false;
  for (int i = 0; i < 100 && !stopped; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    stopped = a.log().find("training job " + id + ": train stopped after a cancel") != std::string::npos;
  }
  EXPECT_TRUE(stopped) << a.log();
  EXPECT_EQ(call(a, "GET", "/v1/jobs/" + id)["state"], "cancelled");
  EXPECT_FALSE(fs::exists(model_dir("cancelled")));
}

}  // namespace
}  // namespace mm::test
