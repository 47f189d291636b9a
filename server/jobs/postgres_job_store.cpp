#include "server/jobs/postgres_job_store.h"

#include <unistd.h>

#include <pqxx/pqxx>
#include <random>

namespace mm::service {
namespace {

constexpr const char* kColumns =
    "id, spec, state, progress, error, published_model, created_at, started_at, finished_at, resumes";

// Serialises the table's creation and the queue-length check of concurrent
// replicas (an arbitrary constant shared by every replica).
constexpr long long kQueueLockKey = 0x6d6d6a6f6273LL;  // "mmjobs"

JobInfo read_row(const pqxx::row& row) {
  JobInfo job;
  job.id = row[0].as<std::string>();
  stored_spec_from_json_text(row[1].as<std::string>(), job);
  job.state = job_state_from_name(row[2].as<std::string>());
  job.progress = progress_from_json_text(row[3].as<std::string>());
  job.error = row[4].as<std::string>();
  job.published_model = row[5].as<std::string>();
  job.created_at = row[6].as<double>();
  job.started_at = row[7].as<double>();
  job.finished_at = row[8].as<double>();
  job.resumes = row[9].as<int>();
  return job;
}

std::string new_replica_name() {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  std::random_device random;
  return std::string(host) + ":" + std::to_string(getpid()) + ":" + std::to_string(random());
}

}  // namespace

PostgresJobStore::PostgresJobStore(const std::string& uri, double lease_seconds)
    : lease_seconds_(lease_seconds), replica_(new_replica_name()), connection_(uri) {
  pqxx::work work(connection());
  work.exec_params("SELECT pg_advisory_xact_lock($1)", kQueueLockKey);
  // seq orders the records by submission (ids are random); lease_until is in
  // the database's clock, the one every replica reads.
  work.exec(
      "CREATE TABLE IF NOT EXISTS training_jobs ("
      " seq BIGSERIAL PRIMARY KEY,"
      " id TEXT NOT NULL UNIQUE,"
      " spec TEXT NOT NULL,"
      " state TEXT NOT NULL,"
      " progress TEXT NOT NULL,"
      " error TEXT NOT NULL DEFAULT '',"
      " published_model TEXT NOT NULL DEFAULT '',"
      " created_at DOUBLE PRECISION NOT NULL,"
      " started_at DOUBLE PRECISION NOT NULL DEFAULT 0,"
      " finished_at DOUBLE PRECISION NOT NULL DEFAULT 0,"
      " resumes INTEGER NOT NULL DEFAULT 0,"
      " owner TEXT NOT NULL DEFAULT '',"
      " lease_until TIMESTAMPTZ)");
  work.exec("CREATE INDEX IF NOT EXISTS training_jobs_state ON training_jobs (state, seq)");
  // Who submitted a job (owner is the replica that runs it); a table made
  // before submitters were recorded gains the column, its jobs nobody's.
  work.exec("ALTER TABLE training_jobs ADD COLUMN IF NOT EXISTS submitter TEXT NOT NULL DEFAULT ''");
  work.commit();
}

PostgresJobStore::~PostgresJobStore() = default;

pqxx::connection_base& PostgresJobStore::connection() const { return connection_.get(); }

QueueRoom PostgresJobStore::insert_within_limits(const JobInfo& job, const std::string& submitter, int max_queued,
                                                 int max_queued_per_submitter) {
  pqxx::work work(connection());
  // Without the lock two replicas could both see room for one more.
  work.exec_params("SELECT pg_advisory_xact_lock($1)", kQueueLockKey);
  const auto counts = work.exec_params(
      "SELECT COUNT(*), COUNT(*) FILTER (WHERE submitter = $1) FROM training_jobs WHERE state = 'queued'",
      submitter)[0];
  if (counts[0].as<long long>() >= max_queued) return QueueRoom::kQueueFull;
  if (counts[1].as<long long>() >= max_queued_per_submitter) return QueueRoom::kSubmitterFull;
  work.exec_params(
      "INSERT INTO training_jobs (id, spec, state, progress, error, published_model, created_at, started_at,"
      " finished_at, resumes, submitter) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11)",
      job.id, stored_spec_to_json_text(job), std::string(job_state_name(job.state)),
      progress_to_json_text(job.progress), job.error, job.published_model, job.created_at, job.started_at,
      job.finished_at, job.resumes, submitter);
  work.commit();
  return QueueRoom::kInserted;
}

bool PostgresJobStore::remove_if_finished(const std::string& id) {
  pqxx::work work(connection());
  const auto result = work.exec_params(
      "DELETE FROM training_jobs WHERE id = $1 AND state IN ('succeeded', 'failed', 'cancelled')", id);
  work.commit();
  return result.affected_rows() == 1;
}

std::optional<JobInfo> PostgresJobStore::find(const std::string& id) const {
  pqxx::read_transaction read(connection());
  const auto rows = read.exec_params(std::string("SELECT ") + kColumns + " FROM training_jobs WHERE id = $1", id);
  if (rows.empty()) return std::nullopt;
  return read_row(rows[0]);
}

std::vector<JobInfo> PostgresJobStore::all() const {
  pqxx::read_transaction read(connection());
  std::vector<JobInfo> jobs;
  for (const auto& row : read.exec(std::string("SELECT ") + kColumns + " FROM training_jobs ORDER BY seq DESC")) {
    jobs.push_back(read_row(row));
  }
  return jobs;
}

std::map<JobState, int> PostgresJobStore::counts() const {
  std::map<JobState, int> counts;
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled}) {
    counts[s] = 0;
  }
  pqxx::read_transaction read(connection());
  for (const auto& row : read.exec("SELECT state, COUNT(*) FROM training_jobs GROUP BY state")) {
    counts[job_state_from_name(row[0].as<std::string>())] = row[1].as<int>();
  }
  return counts;
}

bool PostgresJobStore::unfinished_job_publishes(const std::string& model_name) const {
  pqxx::read_transaction read(connection());
  for (const auto& row : read.exec("SELECT spec FROM training_jobs WHERE state IN ('queued', 'running')")) {
    if (spec_from_json_text(row[0].as<std::string>()).model_name == model_name) return true;
  }
  return false;
}

std::optional<JobInfo> PostgresJobStore::claim_next(double now) {
  pqxx::work work(connection());
  // SKIP LOCKED: a row another replica is claiming right now is passed over,
  // not waited for; one it has just claimed fails the state test when the
  // row is re-read under the lock.
  const auto rows = work.exec_params(
      std::string("UPDATE training_jobs SET state = 'running', owner = $1,"
                  " lease_until = clock_timestamp() + $2 * interval '1 second',"
                  " started_at = CASE WHEN started_at = 0 THEN $3 ELSE started_at END"
                  " WHERE seq = (SELECT seq FROM training_jobs"
                  "  WHERE state = 'queued' OR (state = 'running' AND lease_until < clock_timestamp())"
                  "  ORDER BY seq LIMIT 1 FOR UPDATE SKIP LOCKED)"
                  " RETURNING ") + kColumns,
      replica_, lease_seconds_, now);
  work.commit();
  if (rows.empty()) return std::nullopt;
  return read_row(rows[0]);
}

bool PostgresJobStore::renew_lease(const std::string& id) {
  pqxx::work work(connection());
  const auto result = work.exec_params(
      "UPDATE training_jobs SET lease_until = clock_timestamp() + $1 * interval '1 second'"
      " WHERE id = $2 AND state = 'running' AND owner = $3",
      lease_seconds_, id, replica_);
  work.commit();
  return result.affected_rows() == 1;
}

bool PostgresJobStore::update_state_if(const JobInfo& job, JobState expected) {
  pqxx::work work(connection());
  const std::string state = job_state_name(job.state);
  const auto result = work.exec_params(
      "UPDATE training_jobs SET state = $1, error = $2, published_model = $3, started_at = $4, finished_at = $5,"
      " resumes = $6 WHERE id = $7 AND state = $8"
      " AND (state <> 'running' OR $1 = 'cancelled' OR owner = $9)",
      state, job.error, job.published_model, job.started_at, job.finished_at, job.resumes, job.id,
      std::string(job_state_name(expected)), replica_);
  work.commit();
  return result.affected_rows() == 1;
}

void PostgresJobStore::update_progress(const std::string& id, const JobProgress& progress) {
  pqxx::work work(connection());
  work.exec_params("UPDATE training_jobs SET progress = $1 WHERE id = $2 AND owner = $3",
                   progress_to_json_text(progress), id, replica_);
  work.commit();
}

int PostgresJobStore::requeue_interrupted() { return 0; }

}  // namespace mm::service
