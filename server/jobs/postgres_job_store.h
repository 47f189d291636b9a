// PostgresJobStore: the training jobs' records in a PostgreSQL database that
// several server replicas share, so that they serve one queue.
//
// A replica claims a job atomically (SELECT ... FOR UPDATE SKIP LOCKED: two
// replicas never take the same row) and holds it under a lease, a time in
// the database's clock (no skew between machines matters) that its runner
// renews; a job whose lease expired lost its replica and is claimed by
// another, which resumes it from the checkpoint in the shared state folder.
// The table (training_jobs) is created on first use.
//
// Thread safety: none (see JobStore): one connection, used under the
// owner's mutex. Any number of stores, in any processes, may share the
// database.
// Errors: std::runtime_error (libpqxx's exceptions derive from it) with
// PostgreSQL's message; a connection found closed is opened again on the
// next call.
#pragma once

#include <memory>
#include <string>

#include "server/jobs/job_store.h"
#include "server/jobs/reopening_postgres_connection.h"

namespace mm::service {

class PostgresJobStore final : public JobStore {
 public:
  // Connects to `uri` (a libpq connection URI) and creates the table if it
  // is missing. This store's leases last `lease_seconds`; the replica is
  // named by host, pid and a random number, so a restarted server is a new
  // replica that waits out its predecessor's leases like any other.
  PostgresJobStore(const std::string& uri, double lease_seconds);
  ~PostgresJobStore() override;

  QueueRoom insert_within_limits(const JobInfo& job, const std::string& submitter, int max_queued,
                                 int max_queued_per_submitter) override;
  bool remove_if_finished(const std::string& id) override;
  std::optional<JobInfo> find(const std::string& id) const override;
  std::vector<JobInfo> all() const override;
  std::map<JobState, int> counts() const override;
  bool unfinished_job_publishes(const std::string& model_name) const override;
  std::optional<JobInfo> claim_next(double now) override;
  bool renew_lease(const std::string& id) override;
  // A write that expects `running` is refused unless this replica holds the
  // job or the write is a cancel: a runner that lost its lease cannot undo
  // the work of the replica that took the job over.
  bool update_state_if(const JobInfo& job, JobState expected) override;
  void update_progress(const std::string& id, const JobProgress& progress) override;
  int requeue_interrupted() override;  // 0: leases expire instead

  const std::string& replica() const { return replica_; }

 private:
  pqxx::connection_base& connection() const;  // the open connection, reopened if closed

  double lease_seconds_;
  std::string replica_;
  mutable ReopeningPostgresConnection connection_;
};

}  // namespace mm::service
