#include "server/jobs/job_store.h"

#include <filesystem>
#include <stdexcept>

#include "server/jobs/postgres_job_store.h"
#include "server/jobs/sqlite_job_store.h"

namespace mm::service {

std::unique_ptr<JobStore> open_job_store(const std::string& location, const std::string& state_dir,
                                         double lease_seconds) {
  if (location.empty()) {
    return std::make_unique<SqliteJobStore>((std::filesystem::path(state_dir) / "jobs.sqlite").string());
  }
  if (location.rfind("postgresql://", 0) == 0 || location.rfind("postgres://", 0) == 0) {
    return std::make_unique<PostgresJobStore>(location, lease_seconds);
  }
  // The location may hold a password: only its scheme is repeated.
  throw std::runtime_error("job store: expected empty (SQLite in the state folder) or a postgresql:// URI, got \"" +
                           location.substr(0, location.find(':')) + ":...\"");
}

}  // namespace mm::service
