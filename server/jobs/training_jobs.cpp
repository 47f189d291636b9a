// The queue and its API: submit, get, list, cancel, remove, watch, the
// worker that claims jobs (leases) and the recovery of staged models.
#include "server/jobs/training_jobs.h"

#include <chrono>
#include <filesystem>
#include <mutex>
#include <random>

#include <spdlog/spdlog.h>

#include "server/jobs/job_spec_check.h"
#include "server/jobs/job_store.h"
#include "server/jobs/model_publication.h"
#include "server/jobs/training_jobs_state.h"

namespace mm::service {
namespace {

using namespace jobs_internal;

// How long an idle worker waits before it looks for a job again: one queued
// by another replica wakes nobody here.
constexpr auto kClaimPollInterval = std::chrono::seconds(1);
// A deleted job's folder between its rename and its removal.
const std::string kDeletedPrefix = ".deleted-";

// 12 hex digits (48 random bits): short, and safe as a folder name.
std::string new_job_id() {
  static std::mutex mutex;
  static std::mt19937_64 generator{[] {
    std::random_device device;
    return (static_cast<uint64_t>(device()) << 32) ^ device();
  }()};
  std::lock_guard<std::mutex> lock(mutex);
  char text[13];
  std::snprintf(text, sizeof text, "%012llx", static_cast<unsigned long long>(generator() & 0xffffffffffffULL));
  return text;
}

}  // namespace

using namespace jobs_internal;

TrainingJobs::TrainingJobs(JobsConfig config, std::function<void(const std::string&)> on_published)
    : TrainingJobs(std::move(config), std::move(on_published), JobsTestHooks{}) {}

TrainingJobs::TrainingJobs(JobsConfig config, std::function<void(const std::string&)> on_published,
                           JobsTestHooks hooks)
    : state_(std::make_unique<State>()) {
  state_->config = std::move(config);
  state_->on_published = std::move(on_published);
  state_->hooks = std::move(hooks);
}

TrainingJobs::~TrainingJobs() { shutdown(); }

void TrainingJobs::start() {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.started) return;
  if (s.stopping) throw ApiError(ErrorCode::kUnavailable, "", "training jobs were shut down");
  fs::create_directories(fs::path(s.config.state_dir) / "jobs");
  fs::create_directories(s.config.model_store);
  s.store = open_job_store(s.config.job_store, s.config.state_dir, s.config.lease_seconds);
  // A job still marked running in a SQLite file lost its server; it resumes
  // from its checkpoint when the worker reaches it (oldest first, as it was).
  const int requeued = s.store->requeue_interrupted();
  if (requeued > 0) spdlog::info("training jobs: {} job(s) interrupted by a restart queued again", requeued);
  s.recover_staged_publications();
  // What a deletion left when the server died between rename and removal.
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(fs::path(s.config.state_dir) / "jobs", error)) {
    std::error_code ignored;
    if (entry.path().filename().string().rfind(kDeletedPrefix, 0) == 0) fs::remove_all(entry.path(), ignored);
  }
  s.started = true;
  s.worker = std::thread([&s] { s.worker_loop(); });
}

void TrainingJobs::shutdown() {
  State& s = *state_;
  {
    std::lock_guard<std::mutex> lock(s.mutex);
    s.stopping = true;
    s.changed.notify_all();
  }
  if (s.worker.joinable()) s.worker.join();
}

JobInfo TrainingJobs::submit(const JobSpec& spec, const std::string& submitter) {
  State& s = *state_;
  ResolvedTrainConfig resolved = check_job_spec(spec);
  const int64_t iterations = resolved.config.iterations;
  if (iterations > s.config.max_iterations) {
    const bool own = spec.iterations > 0 || spec.config_json.empty();
    throw ApiError(ErrorCode::kResourceExhausted, own ? "iterations" : "config",
                   (spec.iterations > 0 ? "iterations " : spec.config_json.empty() ? "the variant's iterations "
                                                                                    : "config: iterations: ") +
                       std::to_string(iterations) + " are more than the " + std::to_string(s.config.max_iterations) +
                       " a job may train (the server's --max-job-iterations)",
                   /*too_large=*/true);
  }
  resolve_job_dataset(s.config.data_root, spec.dataset);
  std::lock_guard<std::mutex> lock(s.mutex);
  JobStore& store = s.require_store();
  if (s.stopping) throw ApiError(ErrorCode::kUnavailable, "", "training jobs are shutting down");
  // A name already taken is a conflict with the store's state, not a
  // malformed field: FAILED_PRECONDITION (HTTP 409).
  if (!spec.model_name.empty()) {
    if (fs::exists(fs::path(s.config.model_store) / spec.model_name)) {
      throw ApiError(ErrorCode::kFailedPrecondition, "model_name",
                     "model_name \"" + spec.model_name + "\" is already a model in the store, expected a new name");
    }
    if (store.unfinished_job_publishes(spec.model_name)) {
      throw ApiError(ErrorCode::kFailedPrecondition, "model_name",
                     "model_name \"" + spec.model_name + "\" is the name of an unfinished job's model, expected a new name");
    }
  }
  JobInfo job;
  do {
    job.id = new_job_id();
  } while (store.find(job.id));
  job.spec = spec;
  set_resolved_config(job, std::move(resolved));
  job.state = JobState::kQueued;
  job.created_at = unix_now();
  const QueueRoom room = store.insert_within_limits(job, submitter, s.config.max_queued, s.config.max_queued_per_submitter);
  if (room == QueueRoom::kQueueFull) {
    throw ApiError(ErrorCode::kResourceExhausted, "",
                   "the training queue is full (" + std::to_string(s.config.max_queued) +
                       " queued jobs, --max-queued-jobs), expected fewer; try again when one has started");
  }
  if (room == QueueRoom::kSubmitterFull) {
    const std::string who = submitter == "token" ? "the holders of the server's token" : submitter.substr(submitter.find(':') + 1);
    throw ApiError(ErrorCode::kResourceExhausted, "",
                   "the training queue holds " + std::to_string(s.config.max_queued_per_submitter) + " queued jobs of " +
                       who + ", the most one caller may have (--max-queued-jobs-per-caller); try again when one has "
                       "started");
  }
  spdlog::info("training job {} queued: {}", job.id, spec_to_json_text(spec));
  s.notify_locked();
  return job;
}

JobInfo TrainingJobs::get(const std::string& id) const {
  const State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  auto job = s.require_store().find(id);
  if (!job) throw ApiError(ErrorCode::kNotFound, "id", "no training job with id \"" + id + "\"");
  return *job;
}

std::vector<JobInfo> TrainingJobs::list() const {
  const State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.require_store().all();
}

std::map<JobState, int> TrainingJobs::counts() const {
  const State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  return s.require_store().counts();
}

JobInfo TrainingJobs::cancel(const std::string& id) {
  State& s = *state_;
  std::lock_guard<std::mutex> lock(s.mutex);
  JobStore& store = s.require_store();
  auto job = store.find(id);
  if (!job) throw ApiError(ErrorCode::kNotFound, "id", "no training job with id \"" + id + "\"");
  const JobState was = job->state;
  if (is_terminal(was) || (s.running_id == id && s.publishing)) {
    const std::string state = s.publishing && s.running_id == id ? "publishing its model" : job_state_name(was);
    throw ApiError(ErrorCode::kFailedPrecondition, "id",
                   "training job " + id + " is already " + state + ", expected a queued or running job");
  }
  // The record says cancelled at once; a running child is stopped by the
  // worker (SIGTERM: it finishes its iteration, checkpoints and exits) within
  // a poll interval, and its end can no longer change the record.
  job->state = JobState::kCancelled;
  job->finished_at = unix_now();
  if (s.hooks.before_cancel_commit) s.hooks.before_cancel_commit(id);
  if (!store.update_state_if(*job, was)) {
    // Changed since it was read: another replica finished the job.
    const auto current = store.find(id);
    const std::string state = current ? job_state_name(current->state) : "gone";
    throw ApiError(ErrorCode::kFailedPrecondition, "id",
                   "training job " + id + " is already " + state + ", expected a queued or running job");
  }
  if (s.running_id == id) s.cancel_running = true;
  spdlog::info("training job {} cancelled ({})", id, job_state_name(was));
  s.notify_locked();
  return *job;
}

JobInfo TrainingJobs::remove(const std::string& id) {
  State& s = *state_;
  std::unique_lock<std::mutex> lock(s.mutex);
  JobStore& store = s.require_store();
  auto job = store.find(id);
  if (!job) throw ApiError(ErrorCode::kNotFound, "id", "no training job with id \"" + id + "\"");
  if (!is_terminal(job->state)) {
    throw ApiError(ErrorCode::kFailedPrecondition, "id",
                   "training job " + id + " is " + job_state_name(job->state) +
                       ", expected a finished job; cancel it first");
  }
  // A cancelled job's child may still be checkpointing into the folder.
  if (s.running_id == id) {
    throw ApiError(ErrorCode::kFailedPrecondition, "id",
                   "training job " + id + " was cancelled and its run is still stopping; try again in a few seconds");
  }
  if (!store.remove_if_finished(id)) {
    throw ApiError(ErrorCode::kFailedPrecondition, "id", "training job " + id + " changed meanwhile; try again");
  }
  // Renamed before it is removed: the folder disappears whole at once, and
  // its removal (a checkpoint may be large) holds no one up.
  const fs::path dir = s.job_dir(id);
  const fs::path hidden = dir.parent_path() / (kDeletedPrefix + id);
  std::error_code error;
  fs::rename(dir, hidden, error);
  s.notify_locked();
  lock.unlock();
  if (error == std::errc::no_such_file_or_directory) {
    error.clear();  // a job that never ran has no folder
  } else if (!error) {
    fs::remove_all(hidden, error);
  }
  if (error) spdlog::warn("training job {} deleted, but its folder {} could not be removed: {}", id, dir.string(), error.message());
  spdlog::info("training job {} ({}) deleted with its folder", id, job_state_name(job->state));
  return *job;
}

void TrainingJobs::watch(const std::string& id, const std::function<bool(const JobInfo&)>& on_event,
                         const std::atomic<bool>* stop) const {
  const State& s = *state_;
  JobInfo job = get(id);
  std::string sent = job_to_json_text(job);
  if (!on_event(job) || is_terminal(job.state)) return;
  std::unique_lock<std::mutex> lock(s.mutex);
  uint64_t seen = s.version;
  while (true) {
    s.changed.wait_for(lock, std::chrono::milliseconds(kPollMilliseconds),
                       [&] { return s.version != seen || s.stopping; });
    if (stop != nullptr && stop->load()) return;
    // After shutdown nothing changes any more: a job left queued would keep
    // the watcher waiting for ever.
    if (s.stopping && s.version == seen) return;
    // Read at every poll, changed here or not: another replica sharing the
    // store may have changed the record.
    seen = s.version;
    auto current = s.require_store().find(id);
    if (!current) return;
    std::string text = job_to_json_text(*current);
    if (text == sent) continue;
    sent = std::move(text);
    lock.unlock();
    if (!on_event(*current) || is_terminal(current->state)) return;
    lock.lock();
  }
}

void TrainingJobs::State::worker_loop() {
  while (true) {
    JobInfo job;
    {
      std::unique_lock<std::mutex> lock(mutex);
      std::optional<JobInfo> next;
      while (!stopping) {
        try {
          next = store->claim_next(unix_now());
        } catch (const std::exception& e) {
          // An unreadable database: try again shortly rather than end the worker.
          spdlog::error("training jobs: cannot read the queue: {}", e.what());
        }
        if (next) break;
        const uint64_t seen = version;
        changed.wait_for(lock, kClaimPollInterval, [&] { return stopping || version != seen; });
      }
      if (stopping) return;
      job = *next;
      running_id = job.id;
      cancel_running = false;
      lease_lost = false;
      publishing = false;
      notify_locked();
    }
    RunEnd end;
    try {
      end = run_job(job);
    } catch (const std::exception& e) {
      spdlog::error("training job {}: {}", job.id, e.what());
      try {
        finish(job, JobState::kFailed, std::string("the server could not run the job: ") + e.what());
      } catch (const std::exception& again) {
        spdlog::error("training job {}: cannot record its failure: {}", job.id, again.what());
      }
      end = RunEnd::kFailed;
    }
    std::string published;
    {
      std::lock_guard<std::mutex> lock(mutex);
      running_id.clear();
      publishing = false;
      if (end == RunEnd::kSucceeded) published = job.published_model;
      notify_locked();
    }
    if (!published.empty() && on_published) {
      try {
        on_published(published);
      } catch (const std::exception& e) {
        spdlog::error("training job {}: on_published({}) failed: {}", job.id, published, e.what());
      }
    }
  }
}

// A staged model whose job's record says succeeded lost its rename to a
// crash: it is renamed now. Those of cancelled, failed or unknown jobs are
// removed; a queued or running job's (another replica may be staging it)
// are left alone. Called with the mutex held.
void TrainingJobs::State::recover_staged_publications() {
  for (const std::string& id : staged_job_ids(config.model_store)) {
    const auto job = store->find(id);
    if (job && !is_terminal(job->state)) continue;
    if (job && job->state == JobState::kSucceeded && !job->published_model.empty()) {
      try {
        commit_staged_model(config.model_store, job->published_model, id);
        spdlog::info("training job {}: the model {} staged before a restart is published", id, job->published_model);
      } catch (const std::exception& e) {
        spdlog::error("training job {}: cannot publish its staged model: {}", id, e.what());
      }
      continue;
    }
    discard_staged_model(config.model_store, id);
    spdlog::info("training job {}: its staged model is removed ({})", id,
                 job ? job_state_name(job->state) : "no such job");
  }
}

// Records the end of a job still in state `expected`; false when the record
// was changed meanwhile (a cancel got there first).
bool TrainingJobs::State::finish(JobInfo& job, JobState state, const std::string& error, JobState expected) {
  std::lock_guard<std::mutex> lock(mutex);
  job.state = state;
  job.error = error;
  if (is_terminal(state)) job.finished_at = unix_now();
  const bool written = store->update_state_if(job, expected);
  notify_locked();
  return written;
}

}  // namespace mm::service
