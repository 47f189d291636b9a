// SqliteJobStore: the training jobs' records in one SQLite database file
// (<state_dir>/jobs.sqlite), the embedded default for a single server.
//
// The database runs in WAL mode; every change is one statement or one
// transaction, so a record is never half-written, whatever kills the process.
// There are no leases: the file belongs to one server, which queues its
// running jobs again when it starts (requeue_interrupted()).
//
// Thread safety: none (see JobStore); SQLite itself runs in its serialized
// mode regardless.
// Errors: std::runtime_error with SQLite's message.
#pragma once

#include <memory>
#include <string>

#include "server/jobs/job_store.h"

struct sqlite3;

namespace mm::service {

// An open SQLite connection, closed with the object.
class SqliteDatabase {
 public:
  explicit SqliteDatabase(const std::string& path);  // opens or creates
  ~SqliteDatabase();
  SqliteDatabase(const SqliteDatabase&) = delete;
  SqliteDatabase& operator=(const SqliteDatabase&) = delete;

  void execute(const std::string& sql);  // statements without parameters or results
  sqlite3* handle() const { return db_; }

 private:
  sqlite3* db_ = nullptr;
};

// BEGIN IMMEDIATE ... COMMIT; rolled back when destroyed uncommitted (an
// exception between the two leaves nothing written).
class SqliteTransaction {
 public:
  explicit SqliteTransaction(SqliteDatabase& db);
  ~SqliteTransaction();
  SqliteTransaction(const SqliteTransaction&) = delete;
  SqliteTransaction& operator=(const SqliteTransaction&) = delete;
  void commit();

 private:
  SqliteDatabase& db_;
  bool done_ = false;
};

class SqliteJobStore final : public JobStore {
 public:
  // Opens or creates the database at `path` (its folder must exist).
  explicit SqliteJobStore(const std::string& path);

  QueueRoom insert_within_limits(const JobInfo& job, const std::string& submitter, int max_queued,
                                 int max_queued_per_submitter) override;
  bool remove_if_finished(const std::string& id) override;
  std::optional<JobInfo> find(const std::string& id) const override;
  std::vector<JobInfo> all() const override;
  std::map<JobState, int> counts() const override;
  bool unfinished_job_publishes(const std::string& model_name) const override;
  std::optional<JobInfo> claim_next(double now) override;
  bool renew_lease(const std::string& id) override;
  bool update_state_if(const JobInfo& job, JobState expected) override;
  void update_progress(const std::string& id, const JobProgress& progress) override;
  int requeue_interrupted() override;

 private:
  std::unique_ptr<SqliteDatabase> db_;
};

}  // namespace mm::service
