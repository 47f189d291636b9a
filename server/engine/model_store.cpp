#include "server/engine/model_store.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <spdlog/spdlog.h>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "server/core/service_metrics.h"
#include "server/jobs/active_model_record.h"

namespace mm::service {
namespace fs = std::filesystem;
namespace {

const char* const kManifest = "manifest.json";
// A deleted model's folder between its rename and its removal.
const char* const kDeletedPrefix = ".deleted-";

bool is_plain_name(const std::string& name) {
  // A leading dot marks a folder being copied in (a job publishing its model).
  if (name.empty() || name.size() > 128 || name.front() == '.') return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-'; });
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return {};
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The manifest and the weight files of a model folder, in name order.
std::vector<fs::path> versioned_files(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const auto name = entry.path().filename().string();
    if (entry.is_regular_file() && (name == kManifest || entry.path().extension() == ".pt")) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Names, sizes and modification times: what tells that the files changed.
std::string file_stamp(const std::vector<fs::path>& files) {
  std::string stamp;
  for (const auto& file : files) {
    stamp += file.filename().string() + ":" + std::to_string(fs::file_size(file)) + ":" +
             std::to_string(fs::last_write_time(file).time_since_epoch().count()) + ";";
  }
  return stamp;
}

// FNV-1a over the manifest and the weight files, in name order: a model whose
// files are copied elsewhere keeps its version, one retrained gets another.
std::string content_version(const std::vector<fs::path>& files) {
  uint64_t hash = 1469598103934665603ull;
  std::vector<char> buffer(1 << 16);
  for (const auto& file : files) {
    std::ifstream in(file, std::ios::binary);
    while (in) {
      in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
      for (std::streamsize i = 0; i < in.gcount(); ++i) {
        hash ^= static_cast<unsigned char>(buffer[static_cast<size_t>(i)]);
        hash *= 1099511628211ull;
      }
    }
  }
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

ApiError not_loadable(const std::string& name, const std::string& reason) {
  return ApiError(ErrorCode::kFailedPrecondition, "model", "model \"" + name + "\" cannot be loaded: " + reason);
}

}  // namespace

std::string ModelStore::version_of(const std::string& dir) const {
  const auto files = versioned_files(dir);
  const std::string stamp = file_stamp(files);
  {
    std::lock_guard<std::mutex> lock(versions_mutex_);
    const auto known = versions_.find(dir);
    if (known != versions_.end() && known->second.first == stamp) return known->second.second;
  }
  const std::string version = content_version(files);
  std::lock_guard<std::mutex> lock(versions_mutex_);
  versions_[dir] = {stamp, version};
  return version;
}

ModelStore::ModelStore(std::string root, ServiceMetrics& metrics, int max_loaded, ModelPrecisions precisions)
    : root_(std::move(root)), metrics_(metrics), max_loaded_(std::max(1, max_loaded)), precisions_(std::move(precisions)) {}

std::string ModelStore::folder(const std::string& name) const {
  if (!is_plain_name(name)) {
    throw ApiError(ErrorCode::kInvalidArgument, "model",
                   "expected a model name (letters, digits, '.', '_', '-'), found \"" + name + "\"");
  }
  const fs::path dir = fs::path(root_) / name;
  std::error_code error;
  if (!fs::is_directory(dir, error) || !fs::is_regular_file(dir / kManifest, error)) {
    throw ApiError(ErrorCode::kNotFound, "model", "no model \"" + name + "\" in the store " + root_);
  }
  return dir.string();
}

std::shared_ptr<const LoadedModel> ModelStore::active() const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!active_) throw ApiError(ErrorCode::kUnavailable, "", "no model is loaded yet");
  return active_;
}

std::shared_ptr<const LoadedModel> ModelStore::cached(const std::string& name, const std::string& version) const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& model : loaded_) {
    if (model->name == name && (version.empty() || model->version == version)) return model;
  }
  return nullptr;
}

void ModelStore::remember(std::shared_ptr<const LoadedModel> model) {
  std::lock_guard<std::mutex> lock(mutex_);
  loaded_.erase(std::remove_if(loaded_.begin(), loaded_.end(),
                               [&](const auto& m) { return m->name == model->name; }),
                loaded_.end());
  loaded_.push_back(std::move(model));
  // Forget the least recently used beyond the limit, never the active one;
  // requests still holding a forgotten model keep it alive until they end.
  while (static_cast<int>(loaded_.size()) > max_loaded_) {
    auto victim = std::find_if(loaded_.begin(), loaded_.end(), [&](const auto& m) { return m != active_; });
    if (victim == loaded_.end()) break;
    loaded_.erase(victim);
  }
}

void ModelStore::forget(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  loaded_.erase(std::remove_if(loaded_.begin(), loaded_.end(), [&](const auto& m) { return m->name == name; }),
                loaded_.end());
}

void ModelStore::touch(const std::shared_ptr<const LoadedModel>& model) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = std::find(loaded_.begin(), loaded_.end(), model);
  // Not remembered any more (forgotten, or deleted meanwhile): it is not
  // brought back, or a deleted model would answer by name again.
  if (found == loaded_.end()) return;
  loaded_.erase(found);
  loaded_.push_back(model);
}

std::shared_ptr<const LoadedModel> ModelStore::load(const std::string& name, bool make_active) {
  std::lock_guard<std::mutex> one_load(load_mutex_);
  auto model = load_locked(name);
  if (make_active) {
    set_active(model);
  } else {
    remember(model);
  }
  return model;
}

std::shared_ptr<const LoadedModel> ModelStore::load_locked(const std::string& name) {
  const std::string dir = folder(name);
  const std::string version = version_of(dir);
  std::shared_ptr<const LoadedModel> model = cached(name, version);
  if (!model) {
    const auto started = std::chrono::steady_clock::now();
    try {
      auto manifold = MotionManifold::load(dir);
      if (const Precision precision = precisions_.of(name); precision != Precision::kFp32) {
        manifold.pack_for_inference(precision);
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      ModelShape shape;
      shape.frames = manifold.config().frames;
      shape.columns = manifold.normalization().input_columns();
      shape.latent = manifold.config().latent;
      shape.layout = layout_name(shape.columns);
      shape.skeleton = manifold.skeleton();
      model = std::shared_ptr<const LoadedModel>(new LoadedModel{name, version, dir, std::move(manifold), shape, seconds});
      metrics_.observe_model_load(name, seconds, true);
    } catch (const std::exception& e) {
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      metrics_.observe_model_load(name, seconds, false);
      // LibTorch's messages carry a C++ backtrace after the first line.
      std::string reason = e.what();
      reason = reason.substr(0, reason.find('\n'));
      throw not_loadable(name, reason);
    }
  }
  return model;
}

void ModelStore::set_active(const std::shared_ptr<const LoadedModel>& model) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    active_ = model;
  }
  remember(model);
}

std::shared_ptr<const LoadedModel> ModelStore::get(const std::string& name) {
  if (name.empty()) return active();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (active_ && active_->name == name) return active_;
  }
  // A named model that is loaded answers as loaded; a change of its files is
  // taken up by activation, not by every request (hashing costs a file read).
  // Its folder is still looked for (two stats): another replica sharing the
  // store may have deleted it.
  if (auto model = cached(name, "")) {
    std::error_code error;
    if (fs::is_regular_file(fs::path(model->dir) / kManifest, error)) {
      touch(model);
      return model;
    }
    forget(name);
  }
  return load(name, false);
}

std::shared_ptr<const LoadedModel> ModelStore::activate(const std::string& name) {
  std::lock_guard<std::mutex> one_change(load_mutex_);
  auto model = load_locked(name);
  if (shared_) {
    // Loaded first: a model this replica cannot load is never written as
    // the deployment's. Written before it is made active here, so that a
    // failed write leaves this replica as the others.
    try {
      followed_generation_ = shared_->write(name).generation;
    } catch (const std::exception& e) {
      remember(model);
      throw ApiError(ErrorCode::kUnavailable, "model",
                     "model \"" + name + "\" cannot be made the deployment's active model: the shared job store "
                     "refused the write (" + e.what() + "); the active model stays");
    }
  }
  set_active(model);
  return model;
}

void ModelStore::share_active_model(std::shared_ptr<ActiveModelRecord> record) {
  std::lock_guard<std::mutex> one_change(load_mutex_);
  shared_ = std::move(record);
}

bool ModelStore::follow(const std::string& name, int64_t generation) {
  std::lock_guard<std::mutex> one_change(load_mutex_);
  // An activation here wrote this generation, or a later one, already.
  if (generation <= followed_generation_) return false;
  followed_generation_ = generation;
  auto model = load_locked(name);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (active_ == model) return false;
  }
  set_active(model);
  return true;
}

ModelInfo ModelStore::remove(const std::string& name) {
  static std::atomic<uint64_t> deletions{0};
  const fs::path dir = fs::path(root_) / name;
  const fs::path hidden = fs::path(root_) / (std::string(kDeletedPrefix) + name + "-" + std::to_string(::getpid()) + "-" +
                                             std::to_string(deletions++));
  ModelInfo before;
  {
    std::lock_guard<std::mutex> one_change(load_mutex_);
    before = info(name, false);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (active_ && active_->name == name) {
        throw ApiError(ErrorCode::kFailedPrecondition, "model",
                       "model \"" + name + "\" is the active model; activate another one before deleting it");
      }
    }
    // Another replica may have made it the deployment's a moment ago, which
    // this one follows only at its next look at the record.
    if (shared_) {
      std::optional<ActiveModelRecord::Entry> entry;
      try {
        entry = shared_->read();
      } catch (const std::exception& e) {
        throw ApiError(ErrorCode::kUnavailable, "model",
                       "model \"" + name + "\" cannot be deleted now: the shared job store cannot say whether it is "
                       "the deployment's active model (" + e.what() + ")");
      }
      if (entry && entry->model == name) {
        throw ApiError(ErrorCode::kFailedPrecondition, "model",
                       "model \"" + name + "\" is the deployment's active model; activate another one before "
                       "deleting it");
      }
    }
    std::error_code error;
    fs::rename(dir, hidden, error);
    if (error) {
      throw ApiError(ErrorCode::kInternal, "model",
                     "model \"" + name + "\" cannot be taken out of the store: " + error.message());
    }
    forget(name);
    std::lock_guard<std::mutex> lock(versions_mutex_);
    versions_.erase(dir.string());
  }
  // Out of the lock: loads need not wait for a large folder's removal.
  // remove_all does not follow links: a model linked into the store loses
  // its link, not the folder it points to.
  std::error_code error;
  fs::remove_all(hidden, error);
  if (error) spdlog::warn("model {} deleted, but {} could not be removed: {}", name, hidden.string(), error.message());
  return before;
}

void ModelStore::remove_deleted_leftovers() {
  // Only remove()'s own names, ".deleted-<name>-<pid>-<n>": the rest of the
  // store is models and the jobs' staging folders (recovered by the jobs,
  // which know whether their job still runs). A folder another replica is
  // removing right now is out of every listing already; removing it here
  // too only races its removal to the same end.
  std::vector<std::string> removed;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(root_, error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(kDeletedPrefix, 0) != 0) continue;
    const size_t counter = name.rfind('-');
    const size_t pid = counter == std::string::npos || counter == 0 ? std::string::npos : name.rfind('-', counter - 1);
    const auto digits = [&](size_t from, size_t to) {
      return to > from && std::all_of(name.begin() + static_cast<std::ptrdiff_t>(from),
                                       name.begin() + static_cast<std::ptrdiff_t>(to),
                                       [](char c) { return c >= '0' && c <= '9'; });
    };
    if (pid == std::string::npos || pid < std::string(kDeletedPrefix).size() || !digits(pid + 1, counter) ||
        !digits(counter + 1, name.size())) {
      continue;
    }
    std::error_code ignored;
    if (fs::remove_all(entry.path(), ignored) > 0 && !ignored) removed.push_back(name);
  }
  if (!removed.empty()) {
    std::string names;
    for (const auto& name : removed) names += (names.empty() ? "" : ", ") + name;
    spdlog::info("model store: removed {} folder(s) of deletions a crash interrupted: {}", removed.size(), names);
  }
}

ModelInfo ModelStore::info(const std::string& name, bool details) const {
  const fs::path dir = folder(name);
  ModelInfo info;
  info.name = name;
  info.version = version_of(dir);
  std::shared_ptr<const LoadedModel> loaded = cached(name, info.version);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    info.active = active_ && active_->name == name;
  }
  info.loaded = loaded != nullptr;
  if (loaded) info.load_seconds = loaded->load_seconds;
  info.precision = precision_name(precisions_.of(name));
  // The listing reads the manifest, not the weights: it must not load models.
  const auto manifest = nlohmann::json::parse(read_text(dir / kManifest), nullptr, false);
  if (!manifest.is_discarded() && manifest.is_object()) {
    const auto model = manifest.value("model", nlohmann::json::object());
    info.hidden = model.value("hidden", 0);
    info.latent = model.value("latent", 0);
    info.frames = model.value("frames", 0);
    if (model.value("rotation_decoder", false)) info.decoders.push_back("rotation");
    if (model.value("velocity_decoder", false)) info.decoders.push_back("velocity");
    const auto provenance = manifest.value("provenance", nlohmann::json::object());
    info.variant = provenance.value("variant", "");
    if (details) info.provenance_json = provenance.dump();
    if (details && manifest.contains("skeleton")) info.skeleton_json = manifest["skeleton"].dump();
    info.trajectory = manifest.contains("trajectory");
    try {
      const Skeleton skeleton = manifest.contains("skeleton")
                                    ? Skeleton::from_json_text(manifest["skeleton"].dump(), kManifest)
                                    : Skeleton::h36m();
      info.feet = find_feet(skeleton).names;
    } catch (const InputError&) {
      // A malformed skeleton is reported when the model is loaded.
    }
  }
  if (loaded) {
    info.columns = loaded->shape.columns;
    info.layout = loaded->shape.layout;
  } else if (!manifest.is_discarded() && manifest.contains("normalization")) {
    const auto& mean = manifest["normalization"].value("mean", nlohmann::json::array());
    info.columns = static_cast<int>(mean.size());
    info.layout = info.columns > 0 ? layout_name(info.columns) : "";
  }
  if (details) {
    const auto evaluation = read_text(dir / "evaluation.json");
    if (!evaluation.empty()) info.evaluation_json = evaluation;
    info.model_card = read_text(dir / "MODEL_CARD.md");
  }
  return info;
}

std::vector<ModelInfo> ModelStore::list() const {
  std::vector<std::string> names;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(root_, error)) {
    const auto name = entry.path().filename().string();
    if (is_plain_name(name) && name.front() != '.' && fs::is_regular_file(entry.path() / kManifest, error)) {
      names.push_back(name);
    }
  }
  std::sort(names.begin(), names.end());
  std::vector<ModelInfo> models;
  for (const auto& name : names) models.push_back(info(name, false));
  return models;
}

ModelInfo ModelStore::describe(const std::string& name) const { return info(name, true); }

}  // namespace mm::service
