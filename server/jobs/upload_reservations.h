// UploadReservations: the uploads in flight on every replica of a
// deployment, as rows in the PostgreSQL database the replicas share with
// their job store, so that the data root's quota (--max-data-root-bytes,
// --max-data-root-files) holds for the deployment and not per replica.
//
// An upload checks the quota and takes its reservation in one transaction
// under a lock every replica takes (pg_advisory_xact_lock), so two uploads
// on two replicas are checked one after the other, the second seeing the
// first's bytes as reserved while they are not yet on disk. The row is
// deleted once the file is in place (the file then counts itself); a row
// whose replica died before that lapses after kReservationSeconds, so a
// crash holds its bytes against the quota for at most that long.
//
// Thread safety: every method may be called concurrently (one connection
// under a mutex). Errors: std::runtime_error (libpqxx's) with PostgreSQL's
// message; a connection found closed is opened again on the next call.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

#include "server/jobs/reopening_postgres_connection.h"

namespace mm::service {

class UploadReservations {
 public:
  // An upload's whole write (64 MiB at most, from memory) takes seconds;
  // ten minutes leaves room for a slow shared file system, and is how long
  // a dead replica's reservation still counts.
  static constexpr int kReservationSeconds = 600;

  // What the live reservations of every replica hold together.
  struct Reserved {
    int64_t bytes = 0;
    int64_t files = 0;
  };

  // Connects to `uri` (a libpq connection URI) and creates the table if it
  // is missing; `replica` names the reserving replica in its rows.
  UploadReservations(const std::string& uri, std::string replica);
  ~UploadReservations();

  // Under the deployment-wide lock: calls `check` with what the others have
  // reserved (it looks at the data root and throws to refuse), then reserves
  // `bytes` for one file at `path`; returns the reservation's id. What
  // `check` throws is thrown on, nothing reserved.
  int64_t reserve(const std::string& path, int64_t bytes, const std::function<void(const Reserved&)>& check);
  // Gives reservation `id` back (the file is in place, or was not written).
  void release(int64_t id);

 private:
  const std::string replica_;
  std::mutex mutex_;
  ReopeningPostgresConnection connection_;  // under mutex_
};

}  // namespace mm::service
