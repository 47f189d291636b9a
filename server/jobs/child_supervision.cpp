// The supervision of one child process of the tool: started at low
// priority with its log, its progress lines read and written to the record,
// the lease renewed, stopped (SIGTERM, then SIGKILL) on a cancel, a
// shutdown, a lost lease or the wall-time limit, and its exit status turned
// into how the job ended.
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>

#include <spdlog/spdlog.h>

#include "server/jobs/child_process.h"
#include "server/jobs/training_jobs_state.h"

namespace mm::service {
namespace {

using namespace jobs_internal;

// How long a stopped child may take to checkpoint and export after SIGTERM
// before it is killed; a kill loses at most checkpoint_every iterations.
constexpr auto kStopGrace = std::chrono::seconds(60);
// Progress reaches the database at most this often (the last one always).
constexpr auto kProgressWriteInterval = std::chrono::milliseconds(500);
// Lines of the child's log kept in a failed job's error.
constexpr size_t kErrorLogLines = 12;

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

// How often a runner renews its lease (and so sees a cancel written by
// another replica): three times a lease, and at least every 2 s.
Clock::duration lease_renew_interval(double lease_seconds) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::min(lease_seconds / 3, 2.0)));
}

}  // namespace

using namespace jobs_internal;

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
  ChildProcess child({argv, config.training_threads, log.string(), /*stdout_to_pipe=*/true,
                      config.training_at_lowest_priority});
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
