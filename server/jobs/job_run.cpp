// The run of one job: its dataset prepared (or used in place), the tool's
// train (or resume from the job's checkpoint), and the publication of the
// model it made. Each step's child process is supervised by run_child
// (child_supervision.cpp).
#include <filesystem>
#include <mutex>

#include <spdlog/spdlog.h>

#include "format/atomic_file.h"
#include "server/jobs/job_spec_check.h"
#include "server/jobs/model_publication.h"
#include "server/jobs/training_jobs_state.h"

namespace mm::service {

using namespace jobs_internal;

RunEnd TrainingJobs::State::run_job(JobInfo& job) {
  deadline = config.max_seconds > 0
                 ? Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config.max_seconds))
                 : Clock::time_point::max();
  const fs::path dir = job_dir(job.id);
  fs::create_directories(dir);
  spdlog::info("training job {} started in {}", job.id, dir.string());

  const fs::path run = dir / "run";
  const fs::path checkpoint = run / "checkpoint.pt";
  // A record stored before configurations were resolved was resolved when
  // read (job_record_json.h); one whose spec no longer resolved has none
  // and cannot start (a checkpoint holds its run's configuration).
  if (!job.resolved_config && !fs::exists(checkpoint)) {
    finish(job, JobState::kFailed,
           "the job's record holds no training configuration: it was stored before configurations were resolved at "
           "submission and its spec no longer resolves; submit it again to see why");
    return RunEnd::kFailed;
  }

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
    if (!fs::exists(dataset_file) && dataset.rig_folder) {
      const RunEnd end = run_child(
          job, {config.tool_path, "prepare", "--rig", dataset.path.string(), "--out", dataset_file}, "prepare");
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
    // The configuration resolved at submission, whole, with the server's
    // resume point after a crash (whatever the configuration says) and the
    // run's dataset and folder: the child's argv names no field of the spec.
    ResolvedTrainConfig training = *job.resolved_config;
    training.config.checkpoint_every = config.checkpoint_every;
    training.config.dataset = dataset_file;
    training.config.output_dir = run.string();
    const fs::path config_file = dir / "config.json";
    write_file_atomically(config_file.string(), to_json_text(training) + "\n");
    argv = {config.tool_path, "train", "--config", config_file.string(), "--progress-json"};
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
  if (hooks.before_publication_commit) hooks.before_publication_commit(job.id);
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

}  // namespace mm::service
