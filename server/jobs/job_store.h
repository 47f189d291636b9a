// JobStore: where the training jobs' records live, so that a job's spec,
// state, progress, error and published model survive a restart of the
// server and, with a shared database, are seen by every replica.
//
// Two implementations: SqliteJobStore (one file in --state-dir, the embedded
// default for a single server) and PostgresJobStore (one database shared by
// several replicas). open_job_store() picks one from a location string.
//
// A running job is held by one replica under a lease: claim_next() takes a
// queued job, or a running one whose lease expired (its replica died), and
// the runner keeps the lease with renew_lease() every few seconds. A record
// is never half-written: every change is one statement or one transaction.
//
// Thread safety: none. One JobStore is used under its owner's mutex
// (TrainingJobs). Several JobStores (processes, machines) may share one
// PostgreSQL database; a SQLite file belongs to one server at a time.
// Errors: std::runtime_error with the database's message for a database that
// cannot be opened, read or written.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/jobs/job_record_json.h"

namespace mm::service {

// Whether a submission found room in the queue.
enum class QueueRoom { kInserted, kQueueFull, kSubmitterFull };

class JobStore {
 public:
  virtual ~JobStore() = default;

  // Adds a new record of `submitter` (who sent it) when fewer than
  // `max_queued` jobs are queued and fewer than `max_queued_per_submitter`
  // of them are the submitter's; says which limit refused it otherwise
  // (nothing written). Check and insert are one transaction.
  virtual QueueRoom insert_within_limits(const JobInfo& job, const std::string& submitter, int max_queued,
                                         int max_queued_per_submitter) = 0;
  bool insert_if_room(const JobInfo& job, int max_queued) {
    return insert_within_limits(job, "", max_queued, max_queued) == QueueRoom::kInserted;
  }
  // Deletes the record of job `id` when it is finished (succeeded, failed or
  // cancelled); returns whether it did.
  virtual bool remove_if_finished(const std::string& id) = 0;
  virtual std::optional<JobInfo> find(const std::string& id) const = 0;
  virtual std::vector<JobInfo> all() const = 0;  // newest first
  virtual std::map<JobState, int> counts() const = 0;  // every state, zeros included
  // Whether a queued or running job will publish under `model_name`.
  virtual bool unfinished_job_publishes(const std::string& model_name) const = 0;

  // Atomically takes the oldest job that is queued, or running under an
  // expired lease, for this store's replica: the record becomes running with
  // a fresh lease, and started_at = `now` if it was 0. Returns the record as
  // claimed, or nullopt when there is none. Two replicas never claim the same
  // job while its lease holds.
  virtual std::optional<JobInfo> claim_next(double now) = 0;
  // Renews the lease of running job `id`; returns false (nothing written)
  // when the record is no longer running under this replica: cancelled by
  // any replica, or taken over by another after the lease expired. The
  // runner then stops the job without touching the record.
  virtual bool renew_lease(const std::string& id) = 0;

  // Writes the record's state, error, published model, timestamps and
  // resumes (not spec or progress) when its stored state is `expected`;
  // returns whether it did. The condition keeps a cancel from being undone by
  // a worker that learns of it late.
  virtual bool update_state_if(const JobInfo& job, JobState expected) = 0;
  virtual void update_progress(const std::string& id, const JobProgress& progress) = 0;
  // At start: jobs known to have lost their runner become queued; returns
  // how many. SQLite: every running job (its one server died). PostgreSQL:
  // none; a dead replica's jobs are claimed once their lease expires.
  virtual int requeue_interrupted() = 0;
};

// Opens the store at `location`: "" for SQLite at <state_dir>/jobs.sqlite,
// "postgresql://..." (or "postgres://...", a libpq connection URI) for
// PostgreSQL, whose leases last `lease_seconds`. Throws std::runtime_error
// for another scheme or a database that cannot be opened.
std::unique_ptr<JobStore> open_job_store(const std::string& location, const std::string& state_dir,
                                         double lease_seconds);

}  // namespace mm::service
