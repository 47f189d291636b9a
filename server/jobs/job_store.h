// JobStore: the training jobs' records in one SQLite database file, so that
// a job's spec, state, progress, error and published model survive a restart
// of the server.
//
// The database runs in WAL mode; every change is one statement or one
// transaction, so a record is never half-written, whatever kills the process.
// Spec and progress are stored as JSON text columns: they are read and
// written whole, never queried by part.
//
// Thread safety: none. One JobStore is used under its owner's mutex
// (TrainingJobs); SQLite itself runs in its serialized mode regardless.
// Errors: std::runtime_error with SQLite's message for a database that
// cannot be opened, read or written.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/api_types.h"

struct sqlite3;

namespace mm::service {

// The record as JSON (every field), for logs, the model card and for telling
// whether a record changed.
std::string job_to_json_text(const JobInfo& job);
std::string spec_to_json_text(const JobSpec& spec);

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

class JobStore {
 public:
  // Opens or creates the database at `path` (its folder must exist).
  explicit JobStore(const std::string& path);

  // Adds a new record when fewer than `max_queued` jobs are queued; returns
  // false (nothing written) otherwise. Check and insert are one transaction.
  bool insert_if_room(const JobInfo& job, int max_queued);
  std::optional<JobInfo> find(const std::string& id) const;
  std::vector<JobInfo> all() const;            // newest first
  std::optional<JobInfo> oldest_queued() const;
  std::map<JobState, int> counts() const;      // every state, zeros included
  // Whether a queued or running job will publish under `model_name`.
  bool unfinished_job_publishes(const std::string& model_name) const;

  // Writes the record's state, error, published model, timestamps and
  // resumes (not spec or progress) when its stored state is `expected`;
  // returns whether it did. The condition keeps a cancel from being undone by
  // a worker that learns of it late.
  bool update_state_if(const JobInfo& job, JobState expected);
  void update_progress(const std::string& id, const JobProgress& progress);
  // Running jobs (their server died) become queued; returns how many.
  int requeue_running();

 private:
  std::unique_ptr<SqliteDatabase> db_;
};

}  // namespace mm::service
