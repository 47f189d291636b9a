// The state the training queue (training_jobs.cpp), the run of one job
// (job_run.cpp) and the supervision of its child process
// (child_supervision.cpp) share: TrainingJobs::State. Private to jobs/.
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "server/jobs/job_store.h"
#include "server/jobs/jobs_test_hooks.h"
#include "server/jobs/training_jobs.h"

namespace mm::service::jobs_internal {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// How often the worker, the watchers and a child's supervisor look at their
// stop conditions.
constexpr int kPollMilliseconds = 200;

inline double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// How a child run ended, as the job sees it.
enum class RunEnd { kSucceeded, kFailed, kCancelled, kStopped };

}  // namespace mm::service::jobs_internal

namespace mm::service {

struct TrainingJobs::State {
  using Clock = jobs_internal::Clock;
  using RunEnd = jobs_internal::RunEnd;

  JobsConfig config;
  JobsTestHooks hooks;  // empty in the server
  std::function<void(const std::string&)> on_published;

  mutable std::mutex mutex;
  // Notified on every change of a record and on shutdown: wakes the worker
  // (a job was queued) and the watchers.
  mutable std::condition_variable changed;
  std::unique_ptr<JobStore> store;  // guarded by mutex
  uint64_t version = 0;             // bumped with every change of a record
  bool started = false;
  bool stopping = false;
  std::string running_id;       // the job the worker runs, empty when idle
  bool cancel_running = false;  // cancel() asked the worker to stop it
  bool lease_lost = false;      // another replica took the running job over
  bool publishing = false;      // the running job is past training
  Clock::time_point deadline;   // the running job's end by config.max_seconds (worker thread only)
  std::thread worker;

  JobStore& require_store() const {
    if (!store) throw ApiError(ErrorCode::kUnavailable, "", "training jobs are not started");
    return *store;
  }
  void notify_locked() {
    ++version;
    changed.notify_all();
  }
  std::filesystem::path job_dir(const std::string& id) const {
    return std::filesystem::path(config.state_dir) / "jobs" / id;
  }

  // The queue (training_jobs.cpp): claims jobs and runs them one at a time.
  void worker_loop();
  // One job (job_run.cpp): prepares its dataset, trains, publishes its model.
  RunEnd run_job(JobInfo& job);
  // One child process of the tool (child_supervision.cpp): starts it,
  // forwards its progress, renews the lease, stops it on a cancel, a
  // shutdown or the wall-time limit, and turns its exit into a RunEnd.
  RunEnd run_child(JobInfo& job, const std::vector<std::string>& argv, const std::string& what);
  bool finish(JobInfo& job, JobState state, const std::string& error, JobState expected = JobState::kRunning);
  void recover_staged_publications();
};

}  // namespace mm::service
