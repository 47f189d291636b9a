// Replicas that act as one deployment: with a PostgreSQL job store shared by
// several servers, the active model is the deployment's and the data root's
// quota is checked for the deployment (not per replica). SharedDeployment
// is what a server adds to its model store and its upload quota to take
// part:
//
// - The active model: ActivateModel on any replica writes the shared record
//   (jobs/active_model_record.h); every replica reads it every
//   kFollowInterval on a thread of its own and activates what it names. So a
//   replica answers with the new model at most kFollowInterval plus the
//   model's load after the activation's reply (a model already loaded there
//   is switched to at once). Polling was chosen over a check at each call:
//   it keeps the database off the inference path, and the bound holds for
//   a replica no call reaches. At start, a replica activates the record's
//   model when there is one, else its --default-model.
// - The quota: uploads reserve their bytes in the same database before
//   writing (jobs/upload_reservations.h, through DataRootQuota::shared).
//
// With the SQLite job store (one server) there is nothing to share and
// join_deployment returns null: the server's own activation and quota check
// are the deployment's, as before.
//
// Thread safety: the follower's thread only calls ModelStore, which may be
// called concurrently; the object is made and destroyed by the core's owner.
#pragma once

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "server/core/data_root_clips.h"

namespace mm::service {

class ActiveModelRecord;
class ModelStore;

class SharedDeployment {
 public:
  // How often each replica reads the shared active model.
  static constexpr std::chrono::milliseconds kFollowInterval{1000};

  SharedDeployment(ModelStore& store, std::shared_ptr<ActiveModelRecord> record);
  ~SharedDeployment();  // stops the follower thread
  SharedDeployment(const SharedDeployment&) = delete;
  SharedDeployment& operator=(const SharedDeployment&) = delete;

 private:
  // Reads the record once and follows it; logs, never throws.
  void follow_once();

  ModelStore& store_;
  std::shared_ptr<ActiveModelRecord> record_;
  std::atomic<bool> stopping_{false};
  bool unreachable_logged_ = false;  // one warning per outage of the database
  std::thread thread_;
};

// For a `job_store` that is a PostgreSQL URI ("postgresql://" or
// "postgres://"): opens the shared records, makes the record's active model
// active in `store` (a model that cannot be loaded here leaves the one
// already active, with a warning), shares the record with `store` and
// `quota`, and starts following. Returns null for any other job store
// (SQLite). Throws std::runtime_error when the database cannot be opened.
// Call after the store's model of the start is active, before serving.
std::unique_ptr<SharedDeployment> join_deployment(const std::string& job_store, ModelStore& store,
                                                  DataRootQuota& quota);

}  // namespace mm::service
