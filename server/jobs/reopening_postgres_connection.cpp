#include "server/jobs/reopening_postgres_connection.h"

#include <pqxx/pqxx>

namespace mm::service {

// pqxx::connection is a class template's alias in libpqxx 6 and cannot be
// declared ahead in the header: it lives here.
struct ReopeningPostgresConnection::Connection {
  explicit Connection(const std::string& uri) : connection(uri) {}
  pqxx::connection connection;
};

ReopeningPostgresConnection::ReopeningPostgresConnection(std::string uri) : uri_(std::move(uri)) {}

ReopeningPostgresConnection::~ReopeningPostgresConnection() = default;

pqxx::connection_base& ReopeningPostgresConnection::get() {
  if (!connection_ || !connection_->connection.is_open()) connection_ = std::make_unique<Connection>(uri_);
  return connection_->connection;
}

}  // namespace mm::service
