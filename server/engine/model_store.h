// The model store: a folder of model folders (manifest.json, weights,
// evaluation.json, MODEL_CARD.md, as models/ ships them), the models loaded
// from it, and which one is active.
//
// A loaded model is handed out as a shared_ptr: a request keeps the model it
// started with even when another is activated meanwhile, and a model no
// request holds any more is freed. At most `max_loaded` models stay loaded
// (the active one always among them), so memory stays flat however often
// models are activated. A model whose files changed on disk (another
// version) is loaded afresh on its next activation.
//
// With replicas sharing a PostgreSQL job store, the active model is the
// deployment's (share_active_model): an activation writes the shared record
// and every replica follows it (engine/shared_deployment.h).
//
// Thread safety: every method may be called concurrently.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "model/motion_manifold.h"
#include "server/api/api_types.h"
#include "server/core/model_precisions.h"
#include "server/core/motion_conversion.h"

namespace mm::service {

class ActiveModelRecord;  // jobs/active_model_record.h
class ServiceMetrics;

struct LoadedModel {
  std::string name;
  std::string version;  // 16 hex digits: FNV-1a of the manifest and weight files
  std::string dir;
  MotionManifold model;
  ModelShape shape;
  double load_seconds = 0;
};

class ModelStore {
 public:
  // Each model is loaded with its inference weights in precisions.of(name).
  ModelStore(std::string root, ServiceMetrics& metrics, int max_loaded = 4, ModelPrecisions precisions = {});

  // The folder of model `name` in the store. ApiError NOT_FOUND (field
  // "model") for a name that is not a model folder there, INVALID_ARGUMENT
  // for one that is not a plain folder name.
  std::string folder(const std::string& name) const;

  // The active model; ApiError UNAVAILABLE when none is loaded yet.
  std::shared_ptr<const LoadedModel> active() const;
  // The model a request names: the active one for "", else `name`, loaded
  // if needed (FAILED_PRECONDITION with the loader's reason when it cannot);
  // NOT_FOUND once its folder is gone, even while it is loaded (another
  // replica sharing the store deleted it).
  std::shared_ptr<const LoadedModel> get(const std::string& name);
  // Loads `name` if needed (or if its files changed) and makes it active;
  // on failure the active model stays. With a shared record, the model is
  // loaded here first, then written as the deployment's, then made active
  // here (UNAVAILABLE, the active model staying, when the record cannot be
  // written): a model no replica could load is never the deployment's.
  std::shared_ptr<const LoadedModel> activate(const std::string& name);

  // From now on activate() writes `record`, and follow() reads what other
  // replicas wrote there. Called once, after the model of the start is
  // active and before calls are served.
  void share_active_model(std::shared_ptr<ActiveModelRecord> record);
  // Makes the record's model (written as generation `generation`) active
  // here, unless this store already follows that generation or a later
  // one; writes nothing. Returns whether it changed the active model.
  // ApiError as activate() for a model that cannot be loaded here (the
  // active model stays, and the generation counts as followed: it is not
  // tried again until the record changes).
  bool follow(const std::string& name, int64_t generation);

  // Takes model `name` out of the store and returns its description as it
  // was. Its folder is renamed to a hidden name first (".deleted-<name>-..."),
  // so that a listing or a load sees the whole model or none, then removed
  // (a link in the store is removed, never what it points to); the model is
  // forgotten in memory, and calls that hold it finish on it. Activations,
  // loads and deletions are serialised, so a model being deleted is never
  // made active. ApiError as folder() gives for the name;
  // FAILED_PRECONDITION "model" for the active model.
  ModelInfo remove(const std::string& name);
  // Removes what remove() left behind when the server died between the
  // rename and the removal.
  void remove_deleted_leftovers();

  // Every model folder of the store, sorted by name; describe adds the
  // provenance, evaluation and model card.
  std::vector<ModelInfo> list() const;
  ModelInfo describe(const std::string& name) const;

 private:
  // Loads `name` if it is not loaded in its current version, remembers it
  // and, with `make_active`, makes it active; under load_mutex_.
  std::shared_ptr<const LoadedModel> load(const std::string& name, bool make_active);
  std::shared_ptr<const LoadedModel> load_locked(const std::string& name);  // load_mutex_ held, nothing made active
  void set_active(const std::shared_ptr<const LoadedModel>& model);  // and remembered
  std::shared_ptr<const LoadedModel> cached(const std::string& name, const std::string& version) const;
  void remember(std::shared_ptr<const LoadedModel> model);
  void touch(const std::shared_ptr<const LoadedModel>& model);  // most recently used, if still remembered
  void forget(const std::string& name);  // no longer remembered (calls holding it keep it)
  ModelInfo info(const std::string& name, bool details) const;
  // content_version of `dir`, hashed again only when a file's size or
  // modification time changed: a listing must not read every model's weights.
  std::string version_of(const std::string& dir) const;

  const std::string root_;
  ServiceMetrics& metrics_;
  const int max_loaded_;
  const ModelPrecisions precisions_;
  mutable std::mutex mutex_;
  std::shared_ptr<const LoadedModel> active_;
  std::shared_ptr<ActiveModelRecord> shared_;  // set once before serving; null without replicas
  int64_t followed_generation_ = 0;  // of the shared record, under load_mutex_
  std::vector<std::shared_ptr<const LoadedModel>> loaded_;  // most recently used last
  std::mutex load_mutex_;  // one load, activation or deletion at a time: loads are large
  mutable std::mutex versions_mutex_;
  mutable std::map<std::string, std::pair<std::string, std::string>> versions_;  // dir -> (file stamp, version)
};

}  // namespace mm::service
