// Several replicas of the real server on one PostgreSQL job store (a
// throwaway cluster), one shared state folder and one shared model store:
// submitted jobs run exactly once whichever replica took them, a replica
// SIGKILLed mid-job has its job taken over by the other once the lease
// expires, resumed from its checkpoint into the uninterrupted run's weights,
// and a cancel sent to one replica stops the job running on the other. The
// replicas act as one deployment: a model activated on one answers on every
// other within the stated bound (the poll period plus the model's load), a
// replica started later starts with it, and an upload in flight on one
// counts against the data root's quota on another, its temporary file
// surviving another replica's start.
#include <gtest/gtest.h>
#include <httplib.h>

#include <signal.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "tests/common/test_environment.h"
#include "tests/server/postgres_cluster.h"
#include "tests/server/rest_call.h"
#include "tests/server/server_process.h"

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
  ServerProcess& start_replica(const std::vector<std::string>& more = {}) {
    std::vector<std::string> args = {
        "--job-store", uri_, "--job-lease-seconds", "3", "--state-dir", (shared_ / "state").string(),
        "--data-root", (shared_ / "data").string(), "--model-store", (shared_ / "models").string(),
        "--checkpoint-every", "5", "--auth-token", kToken};
    args.insert(args.end(), more.begin(), more.end());
    replicas_.push_back(std::make_unique<ServerProcess>(args));
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

// The model a Sample without a model answers with on `server`.
std::string sampling_model(const ServerProcess& server) {
  return call(server, "POST", "/v1/sample", json{{"count", 1}, {"seed", 1}})["answered_by"]["model"];
}

// Polls GetModelInfo of `model` on `server` (cheap: no inference on the
// clock) until it says active, then checks that a Sample answers with it;
// returns the seconds from `since` until it was active, and its load time there.
std::pair<double, double> seconds_until_active(const ServerProcess& server, const std::string& model,
                                               std::chrono::steady_clock::time_point since) {
  const auto start = since;
  for (int i = 0; i < 3000; ++i) {
    const json described = call(server, "GET", "/v1/models/" + model);
    if (described.value("active", false)) {
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      EXPECT_EQ(sampling_model(server), model);
      return {seconds, described.value("load_seconds", 0.0)};
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ADD_FAILURE() << model << " never became active:\n" << server.log();
  return {1e9, 0};
}

TEST_F(ReplicasTest, AModelActivatedOnOneReplicaAnswersOnEveryReplicaWithinASecondAndItsLoad) {
  ServerProcess& a = start_replica();
  ServerProcess& b = start_replica();
  ServerProcess& c = start_replica();
  for (const ServerProcess* replica : {&a, &b, &c}) EXPECT_EQ(sampling_model(*replica), "h36m-dkgm-h100");

  // README, "Several replicas": the others follow within 1 s (their poll of
  // the shared record) plus the model's load there; 0.5 s more for a reply
  // on a machine busy with other tests.
  std::chrono::steady_clock::time_point replied;
  const auto expect_followed = [&](const ServerProcess& replica, const std::string& model, const char* name) {
    const auto [seconds, load_seconds] = seconds_until_active(replica, model, replied);
    std::cout << "replica " << name << " answered with " << model << " " << seconds << " s after the activation's reply"
              << " (its load: " << load_seconds << " s)\n";
    EXPECT_LE(seconds, 1.0 + load_seconds + 0.5) << name;
  };
  EXPECT_EQ(call(a, "POST", "/v1/models/h36m-dkgm-cpu:activate")["active"], true);
  replied = std::chrono::steady_clock::now();
  expect_followed(b, "h36m-dkgm-cpu", "b");
  expect_followed(c, "h36m-dkgm-cpu", "c");
  EXPECT_EQ(sampling_model(a), "h36m-dkgm-cpu");

  // Back, from another replica: a model already loaded everywhere.
  EXPECT_EQ(call(c, "POST", "/v1/models/h36m-dkgm-h100:activate")["active"], true);
  replied = std::chrono::steady_clock::now();
  expect_followed(a, "h36m-dkgm-h100", "a");
  expect_followed(b, "h36m-dkgm-h100", "b");

  // A replica started later serves the deployment's model from its first
  // call, not its --default-model, and refuses to delete it.
  EXPECT_EQ(call(b, "POST", "/v1/models/h36m-dkgm-cpu:activate")["active"], true);
  ServerProcess& d = start_replica({"--default-model", "h36m-dkgm-h100"});
  EXPECT_EQ(sampling_model(d), "h36m-dkgm-cpu") << d.log();
  EXPECT_EQ(call(d, "GET", "/v1/models/h36m-dkgm-cpu")["active"], true);
  call(d, "DELETE", "/v1/models/h36m-dkgm-cpu", json(), 409);
}

// A valid H3.6M text file of at least `bytes` bytes: S5 walking, repeated.
std::string walking_text(size_t bytes) {
  const std::string walking = file_text(h36m_dataset_dir() / "S5" / "walking_1.txt");
  std::string text;
  while (text.size() < bytes) text += walking;
  return text;
}

// The temporary file of an upload of `name` in `folder`, if there is one.
std::optional<fs::path> temporary_of(const fs::path& folder, const std::string& name) {
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (entry.path().filename().string().rfind("." + name + ".upload.", 0) == 0) return entry.path();
  }
  return std::nullopt;
}

test::Reply upload(const ServerProcess& server, const std::string& path, const std::string& content) {
  return test::post(server.rest_port(), "/v1/clips:upload?path=" + path, content, test::bearer(kToken),
                    "application/octet-stream");
}

TEST_F(ReplicasTest, AnUploadInFlightOnOneReplicaCountsAgainstTheQuotaOnAnotherAndSurvivesItsStart) {
  const std::string content = walking_text(30'000'000);
  const int64_t size = static_cast<int64_t>(content.size());
  fs::create_directories(shared_ / "data" / "mine");
  int64_t visible = 0;  // the links to H3.6M are not counted
  // Room for one upload and half of another.
  const std::vector<std::string> quota = {"--max-data-root-bytes", std::to_string(visible + size + size / 2)};
  ServerProcess& a = start_replica(quota);
  ServerProcess& b = start_replica(quota);
  ServerProcess& c = start_replica(quota);

  // c's upload is stopped (SIGSTOP: the replica lives, its write in flight)
  // as soon as its temporary file appears, so that the bytes on disk are
  // fewer than the room left: only its reservation can tell a. One stopped
  // too late (a busy machine) is let finish, deleted and tried again.
  const fs::path mine = shared_ / "data" / "mine";
  std::string path;
  std::optional<fs::path> temporary;
  int64_t written = 0;
  test::Reply first;
  std::thread in_flight;
  for (int attempt = 0; attempt < 5 && !temporary; ++attempt) {
    path = "mine/first" + std::to_string(attempt) + ".txt";
    const std::string name = fs::path(path).filename().string();
    std::atomic<bool> returned{false};
    in_flight = std::thread([&] {
      first = upload(c, path, content);
      returned = true;
    });
    while (!returned && !(temporary = temporary_of(mine, name))) {
    }
    if (temporary) {
      ::kill(c.pid(), SIGSTOP);
      std::error_code error;
      written = static_cast<int64_t>(fs::file_size(*temporary, error));
      if (!error && written < size / 2) break;  // c stays stopped, its thread waiting
      temporary.reset();
      ::kill(c.pid(), SIGCONT);
    }
    in_flight.join();
    if (first.status == 200) call(c, "DELETE", "/v1/clips?path=" + path);
  }
  if (!temporary) {
    if (in_flight.joinable()) in_flight.join();
    FAIL() << "c's upload could not be stopped mid-write in 5 attempts: " << first.body << "\n" << c.log();
  }
  std::cout << "c stopped with " << written << " of " << size << " bytes written\n";

  const test::Reply second = upload(a, "mine/second.txt", content);
  // b starts again meanwhile: its sweep must leave c's file, whose writer lives.
  const int b_exit = b.terminate();
  b.restart();
  const bool survived = fs::exists(*temporary);
  ::kill(c.pid(), SIGCONT);
  in_flight.join();

  EXPECT_EQ(b_exit, 0);
  EXPECT_TRUE(survived) << "b's start swept c's upload in flight:\n" << b.log();
  EXPECT_EQ(second.status, 413) << second.body;
  EXPECT_NE(second.body.find("uploads in flight on the replicas"), std::string::npos) << second.body;
  EXPECT_EQ(first.status, 200) << first.body;
  EXPECT_EQ(fs::file_size(shared_ / "data" / path), content.size());

  // c's reservation was given back: once its file is deleted, a's upload fits.
  call(b, "DELETE", "/v1/clips?path=" + path);
  const test::Reply again = upload(a, "mine/second.txt", content);
  EXPECT_EQ(again.status, 200) << again.body;
}

}  // namespace
}  // namespace mm::test
