// ActiveModelRecord: the deployment's active model, one row in the
// PostgreSQL database that replicas share with their job store, so that an
// ActivateModel sent to any replica is the whole deployment's: each replica
// reads the row every second (engine/shared_deployment.h) and activates
// what it names. A generation number, raised by every write, tells a
// follower that the row changed even when the same name is written again
// (a model retrained in place is loaded afresh).
//
// A database of its own connection, not the job store's: that one is held
// under the training queue's mutex while the worker claims and renews, and a
// poll every second must not wait behind it. The table (active_model) is
// created on first use. With the SQLite job store (one server) there is no
// record: the server's own activation is the deployment's.
//
// Thread safety: every method may be called concurrently (one connection
// under a mutex). Errors: std::runtime_error (libpqxx's) with PostgreSQL's
// message; a connection found closed is opened again on the next call.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "server/jobs/reopening_postgres_connection.h"

namespace mm::service {

class ActiveModelRecord {
 public:
  struct Entry {
    std::string model;
    int64_t generation = 0;  // 1 for the first write, then one more each write
  };

  // Connects to `uri` (a libpq connection URI) and creates the table if it
  // is missing; `replica` names the writer in the row (for an operator).
  ActiveModelRecord(const std::string& uri, std::string replica);
  ~ActiveModelRecord();

  // The row, or nullopt when no model was ever activated in the deployment
  // (each replica then keeps the one it started with).
  std::optional<Entry> read();
  // Makes `model` the deployment's active model; returns the row written.
  Entry write(const std::string& model);

 private:
  const std::string replica_;
  std::mutex mutex_;
  ReopeningPostgresConnection connection_;  // under mutex_
};

}  // namespace mm::service
