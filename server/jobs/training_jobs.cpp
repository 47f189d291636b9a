#include "jobs/training_jobs.h"

#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <thread>

#include <spdlog/spdlog.h>

#include "jobs/child_process.h"
#include "jobs/job_spec_check.h"
#include "jobs/job_store.h"
#include "jobs/model_publication.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// How long a stopped child may take to checkpoint and export after SIGTERM
// before it is killed; a kill loses at most checkpoint_every iterations.
constexpr auto kStopGrace = std::chrono::seconds(60);
// Progress reaches the database at most this often (the last one always).
constexpr auto kProgressWriteInterval = std::chrono::milliseconds(500);
// How often the worker and watchers look at their stop conditions.
constexpr int kPollMilliseconds = 200;
// How long an idle worker waits before it looks for a job again: one queued
// by another replica wakes nobody here.
constexpr auto kClaimPollInterval = std::chrono::seconds(1);
// A deleted job's folder between its rename and its removal.
const std::string kDeletedPrefix = ".deleted-";
// Lines of the child's log kept in a failed job's error.
constexpr size_t kErrorLogLines = 12;

double unix_now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

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

// The last `count` lines of a log file (a failed child's own explanation).
std::string last_lines(const fs::path& path, size_t count) {
  std::ifstream in(path, std::ios::binary);
  std::deque<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    // A redrawn progress line holds \r-separated states; its last is enough.
    const auto cr = line.rfind('\r');
    if (cr != std::string::npos) line.erase(0, cr + 1);
    if (line.empty()) continue;
    lines.push_back(std::move(line));
    if (lines.size() > count) lines.pop_front();
  }
  std::string text;
  for (const auto& line : lines) text += line + "\n";
  return text;
}

// A progress line of `train --progress-json`; false for any other line.
bool parse_progress(const std::string& line, JobProgress& progress) {
  const auto j = nlohmann::json::parse(line, nullptr, false);
  if (!j.is_object() || !j.contains("iteration") || !j["iteration"].is_number()) return false;
  progress.iteration = j["iteration"].get<int64_t>();
  progress.total = j.value("total", progress.total);
  progress.iterations_per_second = j.value("iterations_per_second", 0.0);
  progress.eta_seconds = j.value("eta_seconds", 0.0);
  // A report without losses (a resumed run with nothing left to do) keeps
  // those of the last iteration that had them.
  if (j.contains("losses") && j["losses"].is_object() && !j["losses"].empty()) {
    progress.losses.clear();
    for (const auto& [name, value] : j["losses"].items()) {
      progress.losses[name] = value.is_number() ? value.get<double>() : std::numeric_limits<double>::quiet_NaN();
    }
  }
  return true;
}

// How a child run ended, as the job sees it.
enum class RunEnd { kSucceeded, kFailed, kCancelled, kStopped };

// How often a runner renews its lease (and so sees a cancel written by
// another replica): three times a lease, and at least every 2 s.
Clock::duration lease_renew_interval(double lease_seconds) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(lease_seconds / 3, 2.0)));
}

}  // namespace

struct TrainingJobs::State {
  JobsConfig config;
  std::function<void(const std::string&)> on_published;

  mutable std::mutex mutex;
  // Notified on every change of a record and on shutdown: wakes the worker
  // (a job was queued) and the watchers.
  mutable std::condition_variable changed;
  std::unique_ptr<JobStore> store;  // guarded by mutex
  uint64_t version = 0;             // bumped with every change of a record
  bool started = false;
  bool stopping = false;
  std::string running_id;       // the job the worker runs, empty when idle
  bool cancel_running = false;  // cancel() asked the worker to stop it
  bool lease_lost = false;      // another replica took the running job over
  bool publishing = false;      // the running job is past training
  Clock::time_point deadline;   // the running job's end by config.max_seconds (worker thread only)
  std::thread worker;

  JobStore& require_store() const {
    if (!store) throw ApiError(ErrorCode::kUnavailable, "", "training jobs are not started");
    return *store;
  }
  void notify_locked() {
    ++version;
    changed.notify_all();
  }
  fs::path job_dir(const std::string& id) const { return fs::path(config.state_dir) / "jobs" / id; }

  void worker_loop();
  RunEnd run_job(JobInfo& job);
  RunEnd run_child(JobInfo& job, const std::vector<std::string>& argv, const std::string& what);
  bool finish(JobInfo& job, JobState state, const std::string& error, JobState expected = JobState::kRunning);
  void recover_staged_publications();
};

TrainingJobs::TrainingJobs(JobsConfig config, std::function<void(const std::string&)> on_published)
    : state_(std::make_unique<State>()) {
  state_->config = std::move(config);
  state_->on_published = std::move(on_published);
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
  check_job_spec(spec);
  const int64_t iterations = job_iterations(spec);
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
  if (s.config.before_cancel_commit) s.config.before_cancel_commit(id);
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

RunEnd TrainingJobs::State::run_job(JobInfo& job) {
  deadline = config.max_seconds > 0
                 ? Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.max_seconds))
                 : Clock::time_point::max();
  const fs::path dir = job_dir(job.id);
  fs::create_directories(dir);
  spdlog::info("training job {} started in {}", job.id, dir.string());

  // Checked again: the data may have changed since the submission.
  JobDataset dataset;
  try {
    dataset = resolve_job_dataset(config.data_root, job.spec.dataset);
  } catch (const ApiError& e) {
    finish(job, JobState::kFailed, e.what());
    return RunEnd::kFailed;
  }
  std::string dataset_file = dataset.path.string();
  if (!dataset.prepared) {
    // The prepared file is written atomically by the tool, so one that
    // exists is whole: a resumed job does not prepare again.
    dataset_file = (dir / "dataset.mmd").string();
    if (!fs::exists(dataset_file) && dataset.bvh_folder) {
      const RunEnd end = run_child(
          job, {config.tool_path, "prepare", "--bvh", dataset.path.string(), "--out", dataset_file}, "prepare");
      if (end != RunEnd::kSucceeded) return end;
    } else if (!fs::exists(dataset_file)) {
      std::string train, test;
      for (const auto& subject : dataset.subjects) {
        std::string& list = subject == "S5" ? test : train;
        list += (list.empty() ? "" : ",") + subject;
      }
      std::vector<std::string> argv{config.tool_path, "prepare", "--data", dataset.path.string(),
                                    "--out",          dataset_file, "--train", train};
      // No S5: no test subjects (the tool's default would be S5).
      argv.insert(argv.end(), {"--test", test});
      const RunEnd end = run_child(job, argv, "prepare");
      if (end != RunEnd::kSucceeded) return end;
    }
  }

  const fs::path run = dir / "run";
  const fs::path checkpoint = run / "checkpoint.pt";
  std::vector<std::string> argv;
  if (fs::exists(checkpoint)) {
    // The trainer's checkpoint holds networks, optimisers, random states and
    // the iteration: the resumed run continues exactly.
    argv = {config.tool_path, "resume", checkpoint.string(), "--dataset", dataset_file, "--progress-json"};
    std::lock_guard<std::mutex> lock(mutex);
    ++job.resumes;
    store->update_state_if(job, JobState::kRunning);
    notify_locked();
  } else {
    // No checkpoint yet: start afresh, without a partial log of a run that
    // died before its first checkpoint.
    fs::remove_all(run);
    nlohmann::json training = job.spec.config_json.empty() ? nlohmann::json{{"variant", job.spec.variant}}
                                                            : nlohmann::json::parse(job.spec.config_json);
    // The server's resume point after a crash, whatever the configuration says.
    training["checkpoint_every"] = config.checkpoint_every;
    const fs::path config_file = dir / "config.json";
    std::ofstream(config_file, std::ios::binary) << training.dump(2) << "\n";
    argv = {config.tool_path, "train", "--config", config_file.string(), "--dataset", dataset_file,
            "--out", run.string(), "--seed", std::to_string(job.spec.seed), "--progress-json"};
    if (job.spec.iterations > 0) argv.insert(argv.end(), {"--iterations", std::to_string(job.spec.iterations)});
    if (job.spec.hidden > 0) argv.insert(argv.end(), {"--hidden", std::to_string(job.spec.hidden)});
    if (job.spec.batch > 0) argv.insert(argv.end(), {"--batch", std::to_string(job.spec.batch)});
  }
  const RunEnd end = run_child(job, argv, argv[1]);
  if (end != RunEnd::kSucceeded) return end;

  {
    std::lock_guard<std::mutex> lock(mutex);
    if (cancel_running) return RunEnd::kCancelled;
    // A cancel written by another replica since the last renewal.
    if (!store->renew_lease(job.id)) return RunEnd::kCancelled;
    publishing = true;  // from here on a cancel sent to this replica is refused
  }
  const std::string name = job.spec.model_name.empty() ? "job-" + job.id : job.spec.model_name;
  bool staged = false;
  try {
    staged = stage_job_model((run / "model").string(), config.model_store, name, job,
                             job_model_card(job, unix_now() - job.started_at));
  } catch (const std::exception& e) {
    finish(job, JobState::kFailed, std::string("publishing the model failed: ") + e.what());
    return RunEnd::kFailed;
  }
  // The model is in place before the record says succeeded, so that whoever
  // reads "succeeded" (this replica's watchers, or another's) can use it.
  // A crash between the two leaves the record running: the job resumes and
  // finds its model published (stage_job_model returns false).
  if (staged) {
    try {
      commit_staged_model(config.model_store, name, job.id);
    } catch (const std::exception& e) {
      discard_staged_model(config.model_store, job.id);
      finish(job, JobState::kFailed, std::string("publishing the model failed: ") + e.what());
      return RunEnd::kFailed;
    }
  }
  // The record is the commit point: another replica may have written a
  // cancel since the renewal above, and a cancelled job keeps no model.
  if (config.before_publication_commit) config.before_publication_commit(job.id);
  job.published_model = name;
  if (!finish(job, JobState::kSucceeded, "")) {
    job.published_model.clear();
    withdraw_job_model(config.model_store, name, job.id);
    spdlog::info("training job {} cancelled by another replica before its model was published", job.id);
    return RunEnd::kCancelled;
  }
  spdlog::info("training job {} succeeded: model {} published", job.id, name);
  return RunEnd::kSucceeded;
}

RunEnd TrainingJobs::State::run_child(JobInfo& job, const std::vector<std::string>& argv, const std::string& what) {
  const fs::path log = job_dir(job.id) / "train.log";
  {
    // A shutdown or cancel that came while the previous step (prepare) ended
    // must not start the next one.
    std::lock_guard<std::mutex> lock(mutex);
    if (cancel_running) return RunEnd::kCancelled;
    if (stopping) {
      job.state = JobState::kQueued;
      store->update_state_if(job, JobState::kRunning);
      notify_locked();
      return RunEnd::kStopped;
    }
  }
  {
    std::ofstream(log, std::ios::app) << "== " << what << " (" << std::fixed << unix_now() << ")\n";
  }
  ChildProcess child({argv, config.training_threads, log.string(), /*stdout_to_pipe=*/true});
  spdlog::info("training job {}: {} running as pid {}", job.id, what, child.pid());

  bool signalled = false, killed = false, timed_out = false;
  Clock::time_point signalled_at, last_write = Clock::now() - kProgressWriteInterval;
  const auto renew_interval = lease_renew_interval(config.lease_seconds);
  const auto lease = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.lease_seconds));
  Clock::time_point renewed = Clock::now(), renew_tried = Clock::now();
  // Renews the lease; a record no longer running here was cancelled (by any
  // replica) or taken over (this replica was presumed dead): either way the
  // child stops and the record is left alone.
  auto renew_lease = [&] {
    renew_tried = Clock::now();
    std::lock_guard<std::mutex> lock(mutex);
    try {
      if (store->renew_lease(job.id)) {
        renewed = renew_tried;
        return;
      }
      const auto current = store->find(job.id);
      if (current && current->state == JobState::kRunning) {
        lease_lost = true;
      } else if (!cancel_running) {
        spdlog::info("training job {} cancelled by another replica", job.id);
      }
      cancel_running = true;
    } catch (const std::exception& e) {
      spdlog::warn("training job {}: cannot renew its lease: {}", job.id, e.what());
      // Past the lease another replica may take the job over: stop writing
      // into its folder.
      if (Clock::now() - renewed > lease) {
        lease_lost = true;
        cancel_running = true;
      }
    }
  };
  bool unwritten = false;
  auto write_progress = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    store->update_progress(job.id, job.progress);
    notify_locked();
    last_write = Clock::now();
    unwritten = false;
  };
  std::vector<std::string> lines;
  bool open = true;
  while (open) {
    lines.clear();
    open = child.read_lines(kPollMilliseconds, lines);
    for (const auto& line : lines) {
      if (parse_progress(line, job.progress)) {
        unwritten = true;
      } else {
        std::ofstream(log, std::ios::app) << line << "\n";  // prepare's summary, say
      }
    }
    if (unwritten && Clock::now() - last_write >= kProgressWriteInterval) write_progress();
    if (Clock::now() - renew_tried >= renew_interval) renew_lease();
    bool stop, lost;
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = stopping || cancel_running;
      lost = lease_lost;
    }
    if (!signalled && Clock::now() >= deadline) {
      spdlog::warn("training job {}: {} passed the wall-time limit of {} s (--max-job-seconds); stopping it", job.id,
                   what, config.max_seconds);
      timed_out = true;
      stop = true;
    }
    if (lost && !killed) {
      // Another replica resumes from the checkpoint now: a SIGTERM's last
      // checkpoint would be written under it (even one already signalled).
      spdlog::warn("training job {}: its lease was lost; killing {}", job.id, what);
      child.signal(SIGKILL);
      killed = signalled = true;
      signalled_at = Clock::now();
    } else if (stop && !signalled) {
      child.signal(SIGTERM);  // the tool finishes its iteration, checkpoints, exports, exits 130
      signalled = true;
      signalled_at = Clock::now();
    } else if (signalled && Clock::now() - signalled_at > kStopGrace) {
      spdlog::warn("training job {}: {} did not stop within {} s of SIGTERM; killing it", job.id, what,
                   std::chrono::duration_cast<std::chrono::seconds>(kStopGrace).count());
      child.signal(SIGKILL);
    }
  }
  const int status = child.wait();
  bool cancelled, stopped, lost;
  {
    std::lock_guard<std::mutex> lock(mutex);
    cancelled = cancel_running;
    stopped = stopping;
    lost = lease_lost;
  }
  if (lost) {
    spdlog::warn("training job {}: {} stopped: another replica took the job over ({})", job.id, what,
                 describe_wait_status(status));
    return RunEnd::kCancelled;
  }
  if (unwritten) write_progress();
  if (cancelled) {
    spdlog::info("training job {}: {} stopped after a cancel ({})", job.id, what, describe_wait_status(status));
    return RunEnd::kCancelled;
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return RunEnd::kSucceeded;
  if (timed_out) {
    // Stopped as a cancel stops it: its checkpoint stays in the job's folder.
    char limit[32];
    std::snprintf(limit, sizeof limit, "%g", config.max_seconds);
    const std::string error = "the job ran for longer than " + std::string(limit) +
                              " s, the server's limit (--max-job-seconds), and was stopped during " + what +
                              " at iteration " + std::to_string(job.progress.iteration) + "; its checkpoint, if any, "
                              "is kept in " + job_dir(job.id).string();
    spdlog::warn("training job {} failed: {}", job.id, error);
    finish(job, JobState::kFailed, error);
    return RunEnd::kFailed;
  }
  if (stopped) {
    // Shut down under it: back to the queue, to resume at the next start.
    std::lock_guard<std::mutex> lock(mutex);
    job.state = JobState::kQueued;
    store->update_state_if(job, JobState::kRunning);
    notify_locked();
    spdlog::info("training job {}: {} stopped by shutdown ({}); left queued", job.id, what,
                 describe_wait_status(status));
    return RunEnd::kStopped;
  }
  const std::string error = "motion-manifold " + what + " " + describe_wait_status(status) +
                            "; the end of its log (" + log.string() + "):\n" + last_lines(log, kErrorLogLines);
  spdlog::warn("training job {} failed: {}", job.id, error);
  finish(job, JobState::kFailed, error);
  return RunEnd::kFailed;
}

}  // namespace mm::service
