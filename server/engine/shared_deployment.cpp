#include "server/engine/shared_deployment.h"

#include <unistd.h>

#include <spdlog/spdlog.h>

#include "server/engine/model_store.h"
#include "server/jobs/active_model_record.h"
#include "server/jobs/upload_reservations.h"

namespace mm::service {
namespace {

bool is_postgres_uri(const std::string& location) {
  return location.rfind("postgresql://", 0) == 0 || location.rfind("postgres://", 0) == 0;
}

// Who wrote a row, for an operator reading the tables.
std::string replica_name() {
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  return std::string(host) + ":" + std::to_string(getpid());
}

}  // namespace

SharedDeployment::SharedDeployment(ModelStore& store, std::shared_ptr<ActiveModelRecord> record)
    : store_(store), record_(std::move(record)) {
  follow_once();  // the deployment's model before the first call is served
  thread_ = std::thread([this] {
    while (!stopping_) {
      // In short sleeps, so that a stopping server does not wait a period.
      const auto next = std::chrono::steady_clock::now() + kFollowInterval;
      while (!stopping_ && std::chrono::steady_clock::now() < next) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      if (!stopping_) follow_once();
    }
  });
}

SharedDeployment::~SharedDeployment() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
}

void SharedDeployment::follow_once() {
  std::optional<ActiveModelRecord::Entry> entry;
  try {
    entry = record_->read();
    if (unreachable_logged_) spdlog::info("the shared active model can be read again");
    unreachable_logged_ = false;
  } catch (const std::exception& e) {
    // The replica keeps serving its active model meanwhile.
    if (!unreachable_logged_) spdlog::warn("the shared active model cannot be read, this replica keeps its own: {}", e.what());
    unreachable_logged_ = true;
    return;
  }
  if (!entry) return;
  try {
    if (store_.follow(entry->model, entry->generation)) {
      spdlog::info("model {} active, as the deployment's record says (generation {})", entry->model,
                   entry->generation);
    }
  } catch (const std::exception& e) {
    spdlog::warn("model {} is the deployment's active model but cannot be activated here, the active model stays: {}",
                 entry->model, e.what());
  }
}

std::unique_ptr<SharedDeployment> join_deployment(const std::string& job_store, ModelStore& store,
                                                  DataRootQuota& quota) {
  if (!is_postgres_uri(job_store)) return nullptr;
  const std::string replica = replica_name();
  auto record = std::make_shared<ActiveModelRecord>(job_store, replica);
  quota.shared = std::make_shared<UploadReservations>(job_store, replica);
  // The model of the start was made active before: this replica's choice
  // until it reads the record, never a write to it.
  store.share_active_model(record);
  return std::make_unique<SharedDeployment>(store, record);
}

}  // namespace mm::service
