#include "server/jobs/job_record_json.h"

#include <limits>
#include <optional>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "server/jobs/job_spec_check.h"

namespace mm::service {
namespace {

using nlohmann::json;

json spec_json(const JobSpec& s) {
  // The seed is kept as text: JSON readers elsewhere may not hold a uint64.
  return {{"dataset", s.dataset},       {"variant", s.variant}, {"config", s.config_json},
          {"iterations", s.iterations}, {"seed", std::to_string(s.seed)}, {"hidden", s.hidden},
          {"batch", s.batch},           {"model_name", s.model_name}};
}

json progress_json(const JobProgress& p) {
  return {{"iteration", p.iteration},
          {"total", p.total},
          {"losses", p.losses},
          {"iterations_per_second", p.iterations_per_second},
          {"eta_seconds", p.eta_seconds}};
}

}  // namespace

std::string spec_to_json_text(const JobSpec& spec) { return spec_json(spec).dump(); }

JobSpec spec_from_json_text(const std::string& text) {
  const json j = json::parse(text);
  JobSpec s;
  s.dataset = j.at("dataset").get<std::string>();
  s.variant = j.at("variant").get<std::string>();
  s.config_json = j.at("config").get<std::string>();
  s.iterations = j.at("iterations").get<int64_t>();
  s.seed = std::stoull(j.at("seed").get<std::string>());
  s.hidden = j.at("hidden").get<int>();
  s.batch = j.at("batch").get<int>();
  s.model_name = j.at("model_name").get<std::string>();
  return s;
}

std::string stored_spec_to_json_text(const JobInfo& job) {
  json j = spec_json(job.spec);
  j["resolved_config"] = job.resolved_config ? to_json_text(*job.resolved_config) : "";
  return j.dump();
}

void set_resolved_config(JobInfo& job, std::optional<ResolvedTrainConfig> config) {
  job.resolved_config = std::move(config);
  job.resolved_config_json = job.resolved_config ? to_json_text(*job.resolved_config) : "";
}

void stored_spec_from_json_text(const std::string& text, JobInfo& job) {
  job.spec = spec_from_json_text(text);
  const json j = json::parse(text);
  const std::string stored = j.contains("resolved_config") ? j["resolved_config"].get<std::string>() : "";
  std::optional<ResolvedTrainConfig> config;
  try {
    // What submission resolved, read back by the rule it was written for
    // (to_json_text of a ResolvedTrainConfig); or the spec resolved now.
    config = stored.empty() ? resolve_job_config(job.spec)
                            : resolve_train_config(stored, "", TrainOverrides{}, "resolved_config", "");
  } catch (const std::exception&) {
    config.reset();
  }
  set_resolved_config(job, std::move(config));
}

std::string progress_to_json_text(const JobProgress& progress) { return progress_json(progress).dump(); }

JobProgress progress_from_json_text(const std::string& text) {
  const json j = json::parse(text);
  JobProgress p;
  p.iteration = j.at("iteration").get<int64_t>();
  p.total = j.at("total").get<int64_t>();
  // A diverged run's NaN is stored as null (JSON has no NaN) and read back.
  for (const auto& [name, value] : j.at("losses").items()) {
    p.losses[name] = value.is_number() ? value.get<double>() : std::numeric_limits<double>::quiet_NaN();
  }
  p.iterations_per_second = j.at("iterations_per_second").get<double>();
  p.eta_seconds = j.at("eta_seconds").get<double>();
  return p;
}

JobState job_state_from_name(const std::string& name) {
  for (JobState s : {JobState::kQueued, JobState::kRunning, JobState::kSucceeded, JobState::kFailed,
                     JobState::kCancelled}) {
    if (name == job_state_name(s)) return s;
  }
  throw std::runtime_error("job database: unknown state \"" + name + "\"");
}

std::string job_to_json_text(const JobInfo& job) {
  return json{{"id", job.id},
              {"spec", spec_json(job.spec)},
              {"resolved_config", job.resolved_config_json},
              {"state", job_state_name(job.state)},
              {"progress", progress_json(job.progress)},
              {"error", job.error},
              {"published_model", job.published_model},
              {"created_at", job.created_at},
              {"started_at", job.started_at},
              {"finished_at", job.finished_at},
              {"resumes", job.resumes}}
      .dump();
}

}  // namespace mm::service
