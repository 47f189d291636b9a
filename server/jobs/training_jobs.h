// Training jobs: a durable queue of runs of the model's trainer, executed one
// at a time in the background, whose records (state, progress, error,
// published model) live in a JobStore and survive a restart: SQLite in the
// state folder by default, or a PostgreSQL database that several replicas
// share (JobsConfig::job_store). With PostgreSQL every replica claims jobs
// from the one queue and holds the job it runs under a lease; a replica that
// dies loses it, and another takes the job over from its last checkpoint.
// That checkpoint lives in the job's folder under state_dir, so replicas
// sharing a database must share state_dir (and the model store) too.
//
// A job runs as a child process of the `motion-manifold` tool (train, or
// resume from the job's checkpoint after a restart) with its threads bounded
// and at the lowest CPU priority, so that it never starves serving on a small
// machine; progress comes back as JSON lines on the child's stdout. A job
// that succeeds publishes its model into the model store (copied to a
// temporary folder, then renamed) under spec.model_name or "job-<id>".
//
// Layout: <state_dir>/jobs.sqlite (the records with SQLite) and one folder
// <state_dir>/jobs/<id>/ per job: train.log (the children's stderr),
// config.json (the configuration the spec resolved to at submission, kept in
// the record as JobInfo::resolved_config, with checkpoint_every set from
// JobsConfig and the run's dataset and output folder; the tool's only
// source of what to train), dataset.mmd
// (prepared from a text tree) and run/ (the tool's output: checkpoint.pt,
// train_log.csv, model/).
// The store gets hidden ".job-<id>.tmp" folders while a model is staged;
// start() finishes or removes those a crash left behind.
//
// Code: this file and training_jobs.cpp are the queue and its API (leases,
// cancel races); job_run.cpp runs one job (prepare, train, publish);
// child_supervision.cpp watches its child processes (progress, lease
// renewal, stop and kill, exit status); training_jobs_state.h is the state
// the three share.
//
// Torch-free: it only starts processes and keeps records.
// Thread safety: every public method may be called from any thread.
#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/jobs/jobs_test_hooks.h"

namespace mm::service {

struct JobsConfig {
  std::string state_dir;    // jobs.sqlite and one folder per job (checkpoint, log, prepared dataset)
  std::string data_root;    // every job's dataset must lie under it
  std::string model_store;  // where a finished job publishes its model
  std::string tool_path;    // the motion-manifold executable
  int training_threads = 1;  // OMP_NUM_THREADS of the child
  // The child at SCHED_IDLE and nice 19, so that training only takes a core
  // that serving leaves idle; false on a replica that only trains.
  bool training_at_lowest_priority = true;
  int checkpoint_every = 100;  // iterations between checkpoints (resume point after a crash)
  int max_queued = 100;      // submissions beyond it: RESOURCE_EXHAUSTED
  int max_queued_per_submitter = 20;  // queued jobs of one submitter (a token, an address)
  int64_t max_iterations = 1'000'000;  // a job's iterations, the spec's or its configuration's
  // A job's wall time on the runner that runs it (prepare and train, from
  // when it is claimed; a resumed job starts again); 0: no limit. Past it the
  // child is stopped as on a cancel (checkpoint kept) and the job fails.
  double max_seconds = 48 * 3600;
  // Where the records live: "" for SQLite at <state_dir>/jobs.sqlite, or a
  // postgresql:// URI for a database shared by several replicas.
  std::string job_store;
  // How long a replica's hold on a running job lasts unless renewed (it is,
  // every lease/3 and at most every 2 s, while the replica lives): the time
  // before another replica takes over the job of one that died.
  double lease_seconds = 30;
};

class TrainingJobs {
 public:
  // `on_published(name)` runs on the worker thread after a job published
  // model `name` into the store.
  TrainingJobs(JobsConfig config, std::function<void(const std::string&)> on_published);
  // The same with hooks a test calls at chosen points (jobs_test_hooks.h).
  TrainingJobs(JobsConfig config, std::function<void(const std::string&)> on_published, JobsTestHooks hooks);
  ~TrainingJobs();  // shutdown()
  TrainingJobs(const TrainingJobs&) = delete;
  TrainingJobs& operator=(const TrainingJobs&) = delete;

  // Opens (or creates) the database and starts the worker. With SQLite, a
  // job found running (the server died under it) is queued again first and
  // resumes from its last checkpoint; with PostgreSQL such a job is taken
  // over once its lease expires. Throws std::runtime_error for a store that
  // cannot be opened.
  void start();

  // Validates the spec (dataset under the data root and a dataset; variant;
  // numbers in range), resolves it into the whole training configuration the
  // job trains (check_job_spec, kept in the record) and queues it
  // for `submitter` (who sent it, as the core names callers: "token",
  // "ip:127.0.0.1"); returns the new record at once. ApiError INVALID_ARGUMENT naming the field otherwise (see
  // job_spec_check.h); RESOURCE_EXHAUSTED (413) "iterations" (or "config")
  // for more than max_iterations; FAILED_PRECONDITION "model_name" for a
  // name already in the store or claimed by an unfinished job;
  // RESOURCE_EXHAUSTED (429) when max_queued jobs are queued, or
  // max_queued_per_submitter of the submitter's; UNAVAILABLE before start()
  // or after shutdown(). The job trains with seed `spec.seed` always.
  JobInfo submit(const JobSpec& spec, const std::string& submitter = "");
  JobInfo get(const std::string& id) const;  // NOT_FOUND for an unknown id
  std::vector<JobInfo> list() const;         // newest first
  // Cancels a queued or running job (a running one stops at its next
  // iteration). FAILED_PRECONDITION for a job already finished.
  // The record says cancelled on return; a running child gets SIGTERM within
  // ~200 ms (within a lease renewal, at most 2 s, when another replica runs
  // it) and exits after its iteration and checkpoint. A job already
  // publishing its model cannot be cancelled (FAILED_PRECONDITION); when
  // another replica runs it, a cancel that reaches the record before the
  // runner commits it wins, and the model, renamed into place just before
  // the commit, is withdrawn. A succeeded record's model is always in place.
  JobInfo cancel(const std::string& id);
  // Removes a finished job (succeeded, failed or cancelled): its record and
  // its folder (<state_dir>/jobs/<id>: log, configuration, prepared
  // dataset, checkpoint, run), renamed to a hidden name first and then
  // removed. A model the job published stays in the store (DeleteModel
  // removes it). Returns the record as it was. NOT_FOUND for an unknown id;
  // FAILED_PRECONDITION for a queued or running job (cancel it first), and
  // for a cancelled one whose child this server is still stopping.
  JobInfo remove(const std::string& id);
  // Calls `on_event` with the job's record now and after every change, until
  // the job is finished (the last call carries the terminal state),
  // `on_event` returns false, or *stop becomes true (looked at every
  // ~200 ms), or shutdown() was called. Runs on the caller's thread.
  void watch(const std::string& id, const std::function<bool(const JobInfo&)>& on_event,
             const std::atomic<bool>* stop) const;
  // Jobs per state, for the metrics.
  std::map<JobState, int> counts() const;

  // Stops the worker: a running job is stopped with a checkpoint and stays
  // queued, to resume at the next start. Idempotent.
  void shutdown();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace mm::service
