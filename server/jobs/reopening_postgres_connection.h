// ReopeningPostgresConnection: one PostgreSQL connection to a fixed URI that
// is opened again when it is found closed, so that a replica goes on after
// the database restarts or drops it, without a restart of its own. The job
// store, the deployment's active model record and the upload reservations
// each hold one: a connection each, so that none waits behind another's
// transaction.
//
// Thread safety: none: its owner uses it under the owner's own mutex (a
// libpqxx connection carries one transaction at a time).
// Errors: std::runtime_error (libpqxx's exceptions derive from it) with
// libpq's message when the database cannot be reached.
#pragma once

#include <memory>
#include <string>

namespace pqxx {
class connection_base;  // libpqxx 6: pqxx::connection is an alias of a template
}

namespace mm::service {

class ReopeningPostgresConnection {
 public:
  // Remembers `uri` (a libpq connection URI); connects on the first get().
  explicit ReopeningPostgresConnection(std::string uri);
  ~ReopeningPostgresConnection();
  ReopeningPostgresConnection(const ReopeningPostgresConnection&) = delete;
  ReopeningPostgresConnection& operator=(const ReopeningPostgresConnection&) = delete;

  // The open connection: the last one while it is open, else a new one to
  // the URI (the closed one is dropped). The reference stays valid until the
  // next get() or the destructor. Throws when a new one cannot be opened.
  pqxx::connection_base& get();

 private:
  struct Connection;
  const std::string uri_;
  std::unique_ptr<Connection> connection_;
};

}  // namespace mm::service
