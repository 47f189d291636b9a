#include "server/jobs/sqlite_job_store.h"

#include <sqlite3.h>

#include <stdexcept>

namespace mm::service {
namespace {

[[noreturn]] void fail(sqlite3* db, const std::string& what) {
  throw std::runtime_error("job database: " + what + ": " + (db ? sqlite3_errmsg(db) : "out of memory"));
}

// A prepared statement, finalized with the object. Parameters bind from 1.
class Statement {
 public:
  Statement(sqlite3* db, const char* sql) : db_(db) {
    if (sqlite3_prepare_v2(db, sql, -1, &stmt_, nullptr) != SQLITE_OK) fail(db, std::string("prepare ") + sql);
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  Statement& bind(int index, const std::string& value) {
    check(sqlite3_bind_text(stmt_, index, value.data(), static_cast<int>(value.size()), SQLITE_TRANSIENT));
    return *this;
  }
  Statement& bind(int index, double value) {
    check(sqlite3_bind_double(stmt_, index, value));
    return *this;
  }
  Statement& bind(int index, int64_t value) {
    check(sqlite3_bind_int64(stmt_, index, value));
    return *this;
  }
  // True while a row is available.
  bool step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    fail(db_, "step");
  }
  void run() {
    while (step()) {
    }
  }
  std::string text(int column) const {
    const auto* value = sqlite3_column_text(stmt_, column);
    return value ? std::string(reinterpret_cast<const char*>(value), sqlite3_column_bytes(stmt_, column)) : "";
  }
  double real(int column) const { return sqlite3_column_double(stmt_, column); }
  int64_t integer(int column) const { return sqlite3_column_int64(stmt_, column); }

 private:
  void check(int rc) {
    if (rc != SQLITE_OK) fail(db_, "bind");
  }
  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

constexpr const char* kColumns =
    "id, spec, state, progress, error, published_model, created_at, started_at, finished_at, resumes";

JobInfo read_row(const Statement& row) {
  JobInfo job;
  job.id = row.text(0);
  stored_spec_from_json_text(row.text(1), job);
  job.state = job_state_from_name(row.text(2));
  job.progress = progress_from_json_text(row.text(3));
  job.error = row.text(4);
  job.published_model = row.text(5);
  job.created_at = row.real(6);
  job.started_at = row.real(7);
  job.finished_at = row.real(8);
  job.resumes = static_cast<int>(row.integer(9));
  return job;
}

}  // namespace

SqliteDatabase::SqliteDatabase(const std::string& path) {
  const int rc = sqlite3_open_v2(path.c_str(), &db_,
                                 SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    throw std::runtime_error("job database: cannot open " + path + ": " + message);
  }
  sqlite3_busy_timeout(db_, 5000);
}

SqliteDatabase::~SqliteDatabase() { sqlite3_close(db_); }

void SqliteDatabase::execute(const std::string& sql) {
  char* error = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
    const std::string message = error ? error : "unknown error";
    sqlite3_free(error);
    throw std::runtime_error("job database: " + sql + ": " + message);
  }
}

SqliteTransaction::SqliteTransaction(SqliteDatabase& db) : db_(db) { db_.execute("BEGIN IMMEDIATE"); }

SqliteTransaction::~SqliteTransaction() {
  if (done_) return;
  try {
    db_.execute("ROLLBACK");
  } catch (...) {
    // Nothing more can be done: SQLite rolls back an open transaction itself
    // when the connection closes.
  }
}

void SqliteTransaction::commit() {
  db_.execute("COMMIT");
  done_ = true;
}

SqliteJobStore::SqliteJobStore(const std::string& path) : db_(std::make_unique<SqliteDatabase>(path)) {
  // WAL: readers never block the worker's writes. synchronous=NORMAL keeps
  // every committed transaction through a crash of the process (not of the
  // machine's power, where the last ones may roll back, still consistent).
  db_->execute("PRAGMA journal_mode=WAL");
  db_->execute("PRAGMA synchronous=NORMAL");
  // seq orders the records by submission (ids are random).
  db_->execute(
      "CREATE TABLE IF NOT EXISTS jobs ("
      " seq INTEGER PRIMARY KEY AUTOINCREMENT,"
      " id TEXT NOT NULL UNIQUE,"
      " spec TEXT NOT NULL,"
      " state TEXT NOT NULL,"
      " progress TEXT NOT NULL,"
      " error TEXT NOT NULL DEFAULT '',"
      " published_model TEXT NOT NULL DEFAULT '',"
      " created_at REAL NOT NULL,"
      " started_at REAL NOT NULL DEFAULT 0,"
      " finished_at REAL NOT NULL DEFAULT 0,"
      " resumes INTEGER NOT NULL DEFAULT 0,"
      " submitter TEXT NOT NULL DEFAULT '')");
  // A database written before submitters were recorded gains the column;
  // its jobs count as nobody's.
  Statement columns(db_->handle(), "SELECT COUNT(*) FROM pragma_table_info('jobs') WHERE name = 'submitter'");
  columns.step();
  if (columns.integer(0) == 0) db_->execute("ALTER TABLE jobs ADD COLUMN submitter TEXT NOT NULL DEFAULT ''");
}

QueueRoom SqliteJobStore::insert_within_limits(const JobInfo& job, const std::string& submitter, int max_queued,
                                               int max_queued_per_submitter) {
  SqliteTransaction transaction(*db_);
  Statement count(db_->handle(),
                  "SELECT COUNT(*), COALESCE(SUM(submitter = ?), 0) FROM jobs WHERE state = 'queued'");
  count.bind(1, submitter);
  count.step();
  if (count.integer(0) >= max_queued) return QueueRoom::kQueueFull;
  if (count.integer(1) >= max_queued_per_submitter) return QueueRoom::kSubmitterFull;
  Statement insert(db_->handle(),
                   "INSERT INTO jobs (id, spec, state, progress, error, published_model, created_at, started_at,"
                   " finished_at, resumes, submitter) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
  insert.bind(1, job.id)
      .bind(2, stored_spec_to_json_text(job))
      .bind(3, std::string(job_state_name(job.state)))
      .bind(4, progress_to_json_text(job.progress))
      .bind(5, job.error)
      .bind(6, job.published_model)
      .bind(7, job.created_at)
      .bind(8, job.started_at)
      .bind(9, job.finished_at)
      .bind(10, static_cast<int64_t>(job.resumes))
      .bind(11, submitter)
      .run();
  transaction.commit();
  return QueueRoom::kInserted;
}

bool SqliteJobStore::remove_if_finished(const std::string& id) {
  Statement remove(db_->handle(),
                   "DELETE FROM jobs WHERE id = ? AND state IN ('succeeded', 'failed', 'cancelled')");
  remove.bind(1, id).run();
  return sqlite3_changes(db_->handle()) == 1;
}

std::optional<JobInfo> SqliteJobStore::find(const std::string& id) const {
  Statement select(db_->handle(), (std::string("SELECT ") + kColumns + " FROM jobs WHERE id = ?").c_str());
  select.bind(1, id);
  if (!select.step()) return std::nullopt;
  return read_row(select);
}

std::vector<JobInfo> SqliteJobStore::all() const {
  Statement select(db_->handle(), (std::string("SELECT ") + kColumns + " FROM jobs ORDER BY seq DESC").c_str());
  std::vector<JobInfo> jobs;
  while (select.step()) jobs.push_back(read_row(select));
  return jobs;
}

std::optional<JobInfo> SqliteJobStore::claim_next(double now) {
  // One server per file: the oldest queued job, taken in one transaction.
  SqliteTransaction transaction(*db_);
  Statement select(db_->handle(),
                   (std::string("SELECT ") + kColumns + " FROM jobs WHERE state = 'queued' ORDER BY seq LIMIT 1").c_str());
  if (!select.step()) return std::nullopt;
  JobInfo job = read_row(select);
  job.state = JobState::kRunning;
  if (job.started_at == 0) job.started_at = now;
  Statement update(db_->handle(), "UPDATE jobs SET state = 'running', started_at = ? WHERE id = ?");
  update.bind(1, job.started_at).bind(2, job.id).run();
  transaction.commit();
  return job;
}

bool SqliteJobStore::renew_lease(const std::string& id) {
  // No lease to renew (nobody else can take the job over); the record is
  // still read, so that a cancel is seen however it was written.
  Statement select(db_->handle(), "SELECT state FROM jobs WHERE id = ?");
  select.bind(1, id);
  return select.step() && select.text(0) == "running";
}

std::map<JobState, int> SqliteJobStore::counts() const {
  std::map<JobState, int> counts;
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled}) {
    counts[s] = 0;
  }
  Statement select(db_->handle(), "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  while (select.step()) counts[job_state_from_name(select.text(0))] = static_cast<int>(select.integer(1));
  return counts;
}

bool SqliteJobStore::unfinished_job_publishes(const std::string& model_name) const {
  // The spec is JSON text; the few unfinished records are decoded here
  // rather than kept in a column of their own.
  Statement select(db_->handle(), "SELECT spec FROM jobs WHERE state IN ('queued', 'running')");
  while (select.step()) {
    if (spec_from_json_text(select.text(0)).model_name == model_name) return true;
  }
  return false;
}

bool SqliteJobStore::update_state_if(const JobInfo& job, JobState expected) {
  Statement update(db_->handle(),
                   "UPDATE jobs SET state = ?, error = ?, published_model = ?, started_at = ?, finished_at = ?,"
                   " resumes = ? WHERE id = ? AND state = ?");
  update.bind(1, std::string(job_state_name(job.state)))
      .bind(2, job.error)
      .bind(3, job.published_model)
      .bind(4, job.started_at)
      .bind(5, job.finished_at)
      .bind(6, static_cast<int64_t>(job.resumes))
      .bind(7, job.id)
      .bind(8, std::string(job_state_name(expected)))
      .run();
  return sqlite3_changes(db_->handle()) == 1;
}

void SqliteJobStore::update_progress(const std::string& id, const JobProgress& progress) {
  Statement update(db_->handle(), "UPDATE jobs SET progress = ? WHERE id = ?");
  update.bind(1, progress_to_json_text(progress)).bind(2, id).run();
}

int SqliteJobStore::requeue_interrupted() {
  Statement update(db_->handle(), "UPDATE jobs SET state = 'queued' WHERE state = 'running'");
  update.run();
  return sqlite3_changes(db_->handle());
}

}  // namespace mm::service
