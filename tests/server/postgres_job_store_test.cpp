// The PostgreSQL job store on a real throwaway cluster: records round-trip,
// the queue's bound, atomic claims across replicas, leases that keep a job,
// expire and let another replica take it over, and a cancel written by any
// replica ending the runner's lease; and, the same on PostgreSQL and SQLite,
// each submitter's own bound on the queue and the removal of finished records
// only.
#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <set>
#include <thread>

#include "server/jobs/job_spec_check.h"
#include "server/jobs/postgres_job_store.h"
#include "server/jobs/sqlite_job_store.h"
#include "tests/server/postgres_cluster.h"

namespace mm::service {
namespace {

using namespace std::chrono_literals;

class PostgresJobStoreTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { cluster_ = new test::PostgresCluster(); }
  static void TearDownTestSuite() {
    delete cluster_;
    cluster_ = nullptr;
  }
  // A fresh database per test.
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("t_") + info->name();
    for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    uri_ = cluster_->create_database(name.substr(0, 60));
  }
  std::unique_ptr<PostgresJobStore> replica(double lease_seconds = 30) {
    return std::make_unique<PostgresJobStore>(uri_, lease_seconds);
  }
  static JobInfo queued_job(const std::string& id, const std::string& model_name = "") {
    JobInfo job;
    job.id = id;
    job.spec.dataset = "small";
    job.spec.variant = "D";
    job.spec.iterations = 12;
    job.spec.seed = 18446744073709551615ULL;  // the largest seed survives the JSON text
    job.spec.model_name = model_name;
    // As submitted: the configuration resolved, which the record keeps.
    set_resolved_config(job, resolve_job_config(job.spec));
    job.state = JobState::kQueued;
    job.created_at = 1700000000.25;
    return job;
  }

  static test::PostgresCluster* cluster_;
  std::string uri_;
};

test::PostgresCluster* PostgresJobStoreTest::cluster_ = nullptr;

TEST_F(PostgresJobStoreTest, RecordsRoundTripAndTheQueueIsBounded) {
  auto store = replica();
  JobInfo job = queued_job("a1", "model-a");
  job.progress.iteration = 3;
  job.progress.losses["kl"] = 0.5;
  ASSERT_TRUE(store->insert_if_room(job, 2));
  EXPECT_EQ(job_to_json_text(*store->find("a1")), job_to_json_text(job));
  EXPECT_FALSE(store->find("none").has_value());
  ASSERT_TRUE(store->insert_if_room(queued_job("a2"), 2));
  EXPECT_FALSE(store->insert_if_room(queued_job("a3"), 2)) << "a full queue took a job";
  EXPECT_EQ(store->all().size(), 2u);
  EXPECT_EQ(store->all().front().id, "a2") << "newest first";
  EXPECT_TRUE(store->unfinished_job_publishes("model-a"));
  EXPECT_FALSE(store->unfinished_job_publishes("model-b"));
  EXPECT_EQ(store->counts().at(JobState::kQueued), 2);
  EXPECT_EQ(store->counts().at(JobState::kFailed), 0);
  EXPECT_EQ(store->requeue_interrupted(), 0);
}

// Each submitter's queued jobs are bounded on their own, within the queue's
// bound; a record is removed only once finished.
void expect_submitter_bounds_and_removal(JobStore& store, const std::string& which) {
  SCOPED_TRACE(which);
  const auto job = [](const std::string& id) {
    JobInfo record;
    record.id = id;
    record.spec.dataset = "small";
    record.created_at = 1700000000;
    return record;
  };
  EXPECT_EQ(store.insert_within_limits(job("t1"), "token", 3, 1), QueueRoom::kInserted);
  EXPECT_EQ(store.insert_within_limits(job("t2"), "token", 3, 1), QueueRoom::kSubmitterFull);
  EXPECT_EQ(store.insert_within_limits(job("i1"), "ip:127.0.0.2", 3, 2), QueueRoom::kInserted);
  EXPECT_EQ(store.insert_within_limits(job("i2"), "ip:127.0.0.2", 3, 2), QueueRoom::kInserted);
  EXPECT_EQ(store.insert_within_limits(job("o1"), "ip:127.0.0.3", 3, 2), QueueRoom::kQueueFull);
  EXPECT_FALSE(store.find("t2").has_value());
  // A job that is no longer queued leaves its submitter's room.
  const auto running = store.claim_next(1700000001);
  ASSERT_TRUE(running.has_value());
  EXPECT_EQ(running->id, "t1");
  EXPECT_EQ(store.insert_within_limits(job("t3"), "token", 3, 1), QueueRoom::kInserted);

  EXPECT_FALSE(store.remove_if_finished("t1")) << "a running record was removed";
  EXPECT_FALSE(store.remove_if_finished("t3")) << "a queued record was removed";
  JobInfo cancelled = *running;
  cancelled.state = JobState::kCancelled;
  ASSERT_TRUE(store.update_state_if(cancelled, JobState::kRunning));
  EXPECT_TRUE(store.remove_if_finished("t1"));
  EXPECT_FALSE(store.find("t1").has_value());
  EXPECT_FALSE(store.remove_if_finished("t1"));
  EXPECT_EQ(store.all().size(), 3u);
}

TEST_F(PostgresJobStoreTest, SubmittersHaveTheirOwnBoundAndOnlyFinishedRecordsAreRemovedInEitherStore) {
  expect_submitter_bounds_and_removal(*replica(), "PostgreSQL");
  const auto folder = std::filesystem::temp_directory_path() / ("mm-sqlite-store-" + std::to_string(getpid()));
  std::filesystem::create_directories(folder);
  {
    SqliteJobStore sqlite((folder / "jobs.sqlite").string());
    expect_submitter_bounds_and_removal(sqlite, "SQLite");
  }
  std::filesystem::remove_all(folder);
}

TEST_F(PostgresJobStoreTest, EveryQueuedJobIsClaimedExactlyOnceByConcurrentReplicas) {
  constexpr int kJobs = 40, kReplicas = 4;
  {
    auto store = replica();
    for (int i = 0; i < kJobs; ++i) ASSERT_TRUE(store->insert_if_room(queued_job("j" + std::to_string(i)), 1000));
  }
  std::vector<std::vector<std::string>> claimed(kReplicas);
  std::vector<std::thread> threads;
  for (int r = 0; r < kReplicas; ++r) {
    threads.emplace_back([&, r] {
      auto store = replica();
      while (auto job = store->claim_next(1.0)) {
        EXPECT_EQ(job->state, JobState::kRunning);
        claimed[r].push_back(job->id);
      }
    });
  }
  for (auto& thread : threads) thread.join();
  std::multiset<std::string> all;
  for (const auto& ids : claimed) all.insert(ids.begin(), ids.end());
  EXPECT_EQ(all.size(), static_cast<size_t>(kJobs));
  for (const auto& id : all) EXPECT_EQ(all.count(id), 1u) << id << " claimed more than once";
  EXPECT_EQ(replica()->counts().at(JobState::kRunning), kJobs);
}

TEST_F(PostgresJobStoreTest, ARenewedLeaseKeepsTheJobAndAnExpiredOneLetsAnotherReplicaTakeItOver) {
  auto first = replica(1.0), second = replica(1.0);
  ASSERT_TRUE(first->insert_if_room(queued_job("x"), 10));
  const auto claimed = first->claim_next(100.0);
  ASSERT_TRUE(claimed.has_value());
  EXPECT_EQ(claimed->started_at, 100.0);
  for (int i = 0; i < 6; ++i) {
    std::this_thread::sleep_for(300ms);
    ASSERT_TRUE(first->renew_lease("x"));
    ASSERT_FALSE(second->claim_next(200.0).has_value()) << "taken while its lease was renewed";
  }
  std::this_thread::sleep_for(1500ms);  // the first replica "died"
  const auto taken = second->claim_next(200.0);
  ASSERT_TRUE(taken.has_value()) << "an expired lease was not taken over";
  EXPECT_EQ(taken->started_at, 100.0) << "a takeover is not a new start";
  // The first replica learns it lost the job, and can no longer write it.
  EXPECT_FALSE(first->renew_lease("x"));
  JobInfo late = *taken;
  late.state = JobState::kFailed;
  EXPECT_FALSE(first->update_state_if(late, JobState::kRunning));
  late.state = JobState::kSucceeded;
  EXPECT_TRUE(second->update_state_if(late, JobState::kRunning));
  EXPECT_EQ(first->find("x")->state, JobState::kSucceeded);
}

TEST_F(PostgresJobStoreTest, ACancelFromAnotherReplicaEndsTheRunnersLease) {
  auto runner = replica(), other = replica();
  ASSERT_TRUE(runner->insert_if_room(queued_job("c"), 10));
  auto job = runner->claim_next(1.0);
  ASSERT_TRUE(job.has_value());
  ASSERT_TRUE(runner->renew_lease("c"));
  job->state = JobState::kCancelled;
  ASSERT_TRUE(other->update_state_if(*job, JobState::kRunning)) << "a cancel needs no lease";
  EXPECT_FALSE(runner->renew_lease("c"));
  EXPECT_FALSE(other->claim_next(2.0).has_value()) << "a cancelled job was claimed";
}

TEST_F(PostgresJobStoreTest, AStoppedJobQueuedAgainIsClaimedAtOnce) {
  auto runner = replica(), other = replica();
  ASSERT_TRUE(runner->insert_if_room(queued_job("s"), 10));
  auto job = runner->claim_next(1.0);
  ASSERT_TRUE(job.has_value());
  job->state = JobState::kQueued;  // a shutdown with a checkpoint
  ASSERT_TRUE(runner->update_state_if(*job, JobState::kRunning));
  const auto taken = other->claim_next(2.0);
  ASSERT_TRUE(taken.has_value());
  EXPECT_EQ(taken->id, "s");
}

}  // namespace
}  // namespace mm::service
