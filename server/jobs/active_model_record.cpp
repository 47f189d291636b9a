#include "server/jobs/active_model_record.h"

#include <pqxx/pqxx>

namespace mm::service {
namespace {

// Serialises the table's creation among replicas starting together (an
// arbitrary constant shared by every replica).
constexpr long long kTableLockKey = 0x6d6d61637476LL;  // "mmactv"

}  // namespace

ActiveModelRecord::ActiveModelRecord(const std::string& uri, std::string replica)
    : replica_(std::move(replica)), connection_(uri) {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::work work(connection_.get());
  work.exec_params("SELECT pg_advisory_xact_lock($1)", kTableLockKey);
  // One row (id = 1): the deployment has one active model.
  work.exec(
      "CREATE TABLE IF NOT EXISTS active_model ("
      " id INTEGER PRIMARY KEY CHECK (id = 1),"
      " model TEXT NOT NULL,"
      " generation BIGINT NOT NULL,"
      " activated_by TEXT NOT NULL,"
      " activated_at TIMESTAMPTZ NOT NULL)");
  work.commit();
}

ActiveModelRecord::~ActiveModelRecord() = default;

std::optional<ActiveModelRecord::Entry> ActiveModelRecord::read() {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::read_transaction read(connection_.get());
  const auto rows = read.exec("SELECT model, generation FROM active_model WHERE id = 1");
  if (rows.empty()) return std::nullopt;
  return Entry{rows[0][0].as<std::string>(), rows[0][1].as<int64_t>()};
}

ActiveModelRecord::Entry ActiveModelRecord::write(const std::string& model) {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::work work(connection_.get());
  // One statement: two replicas activating at once both raise the
  // generation, and the later commit is the deployment's.
  const auto row = work.exec_params(
      "INSERT INTO active_model (id, model, generation, activated_by, activated_at)"
      " VALUES (1, $1, 1, $2, clock_timestamp())"
      " ON CONFLICT (id) DO UPDATE SET model = EXCLUDED.model, generation = active_model.generation + 1,"
      " activated_by = EXCLUDED.activated_by, activated_at = EXCLUDED.activated_at"
      " RETURNING generation",
      model, replica_)[0];
  work.commit();
  return Entry{model, row[0].as<int64_t>()};
}

}  // namespace mm::service
