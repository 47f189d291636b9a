#include "server/jobs/upload_reservations.h"

#include <pqxx/pqxx>

namespace mm::service {
namespace {

// The lock every replica's quota check takes (an arbitrary constant shared
// by every replica); it also serialises the table's creation.
constexpr long long kQuotaLockKey = 0x6d6d71756f7461LL;  // "mmquota"

}  // namespace

UploadReservations::UploadReservations(const std::string& uri, std::string replica)
    : replica_(std::move(replica)), connection_(uri) {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::work work(connection_.get());
  work.exec_params("SELECT pg_advisory_xact_lock($1)", kQuotaLockKey);
  // expires_at is in the database's clock, the one every replica reads.
  work.exec(
      "CREATE TABLE IF NOT EXISTS upload_reservations ("
      " id BIGSERIAL PRIMARY KEY,"
      " replica TEXT NOT NULL,"
      " path TEXT NOT NULL,"
      " bytes BIGINT NOT NULL,"
      " expires_at TIMESTAMPTZ NOT NULL)");
  work.commit();
}

UploadReservations::~UploadReservations() = default;

int64_t UploadReservations::reserve(const std::string& path, int64_t bytes,
                                    const std::function<void(const Reserved&)>& check) {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::work work(connection_.get());
  // Held until the commit: another replica's check waits here until this
  // reservation is visible to it.
  work.exec_params("SELECT pg_advisory_xact_lock($1)", kQuotaLockKey);
  work.exec("DELETE FROM upload_reservations WHERE expires_at < clock_timestamp()");
  const auto totals = work.exec("SELECT COALESCE(SUM(bytes), 0), COUNT(*) FROM upload_reservations")[0];
  check(Reserved{totals[0].as<int64_t>(), totals[1].as<int64_t>()});  // throws to refuse: the transaction aborts
  const auto row = work.exec_params(
      "INSERT INTO upload_reservations (replica, path, bytes, expires_at)"
      " VALUES ($1, $2, $3, clock_timestamp() + $4 * interval '1 second') RETURNING id",
      replica_, path, bytes, kReservationSeconds)[0];
  work.commit();
  return row[0].as<int64_t>();
}

void UploadReservations::release(int64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  pqxx::work work(connection_.get());
  work.exec_params("DELETE FROM upload_reservations WHERE id = $1", id);
  work.commit();
}

}  // namespace mm::service
