#include "server/jobs/model_publication.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "model/training_config.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

std::string marker(const std::string& id) { return "Trained by training job `" + id + "`."; }

// A job's staging folder: <store>/.job-<id>.tmp.
const std::string kStagedPrefix = ".job-";
const std::string kStagedExtension = ".tmp";

fs::path staged_folder(const std::string& store, const std::string& id) {
  return fs::path(store) / (kStagedPrefix + id + kStagedExtension);
}

bool holds_card_of(const fs::path& folder, const std::string& id) {
  std::ifstream in(folder / "MODEL_CARD.md");
  std::stringstream text;
  text << in.rdbuf();
  return in && text.str().find(marker(id)) != std::string::npos;
}

}  // namespace

std::string job_model_card(const JobInfo& job, double training_seconds) {
  const JobSpec& s = job.spec;
  if (!job.resolved_config) {
    throw std::runtime_error("training job " + job.id + ": its record holds no training configuration");
  }
  const TrainConfig& c = job.resolved_config->config;
  std::ostringstream card;
  card << "# " << (s.model_name.empty() ? "job-" + job.id : s.model_name) << "\n\n"
       << marker(job.id) << "\n\n"
       << "## Job\n\n"
       << "| field | value |\n| --- | --- |\n"
       << "| dataset | `" << s.dataset << "` |\n"
       << "| variant | " << c.variant << " |\n"
       << "| config | " << (s.config_json.empty() ? "(none)" : "`" + s.config_json + "`") << " |\n"
       << "| iterations requested | " << c.iterations << " |\n"
       << "| seed | " << c.seed << " |\n"
       << "| hidden | " << c.model.hidden << " |\n"
       << "| batch | " << c.batch << " |\n"
       << "| loss forms | " << loss_preset_name(c.losses) << " |\n"
       << "| iterations trained | " << job.progress.iteration << " of " << job.progress.total << " |\n"
       << "| training time | " << static_cast<long long>(training_seconds + 0.5) << " s |\n"
       << "| resumed after a restart | " << job.resumes << " times |\n\n"
       << "## Final losses\n\n| term | value |\n| --- | --- |\n";
  for (const auto& [name, value] : job.progress.losses) card << "| " << name << " | " << value << " |\n";
  card << "\n## Configuration\n\nWhat the job trained, resolved at submission (model.pose_dims, when absent, were "
          "the dataset's; checkpoint_every was the server's --checkpoint-every):\n\n```json\n"
       << to_json_text(*job.resolved_config) << "\n```\n";
  card << "\nThe run's own provenance (command line, iterations, device) is in manifest.json.\n";
  return card.str();
}

bool stage_job_model(const std::string& model_dir, const std::string& store, const std::string& name,
                     const JobInfo& job, const std::string& model_card) {
  const fs::path source(model_dir), destination = fs::path(store) / name;
  if (!fs::is_regular_file(source / "manifest.json")) {
    throw std::runtime_error("the run exported no model: " + (source / "manifest.json").string() + " is missing");
  }
  fs::create_directories(store);
  if (fs::exists(destination)) {
    if (holds_card_of(destination, job.id)) return false;
    throw std::runtime_error("model_name: a model named \"" + name + "\" already exists in the store");
  }
  const fs::path staged = staged_folder(store, job.id);
  try {
    fs::remove_all(staged);
    fs::copy(source, staged, fs::copy_options::recursive);
    std::ofstream card(staged / "MODEL_CARD.md", std::ios::binary);
    card << model_card;
    card.close();
    if (!card) throw std::runtime_error("cannot write " + (staged / "MODEL_CARD.md").string());
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staged, ignored);
    throw;
  }
  return true;
}

void commit_staged_model(const std::string& store, const std::string& name, const std::string& job_id) {
  const fs::path destination = fs::path(store) / name;
  std::error_code error;
  // rename(2) of a folder onto an existing non-empty one fails, so a model
  // that appeared meanwhile is never replaced.
  fs::rename(staged_folder(store, job_id), destination, error);
  if (!error) return;
  if (!holds_card_of(destination, job_id)) {
    throw std::runtime_error("cannot rename the staged model to " + destination.string() + ": " + error.message());
  }
  discard_staged_model(store, job_id);
}

void withdraw_job_model(const std::string& store, const std::string& name, const std::string& job_id) {
  const fs::path published = fs::path(store) / name;
  if (!holds_card_of(published, job_id)) return;
  std::error_code error;
  fs::rename(published, staged_folder(store, job_id), error);
  if (error) fs::remove_all(published, error);  // not at once, but not kept
  discard_staged_model(store, job_id);
}

void discard_staged_model(const std::string& store, const std::string& job_id) {
  std::error_code ignored;
  fs::remove_all(staged_folder(store, job_id), ignored);
}

std::vector<std::string> staged_job_ids(const std::string& store) {
  std::vector<std::string> ids;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(store, error)) {
    const std::string stem = entry.path().stem().string();
    if (entry.path().extension() == kStagedExtension && stem.size() > kStagedPrefix.size() &&
        stem.rfind(kStagedPrefix, 0) == 0) {
      ids.push_back(stem.substr(kStagedPrefix.size()));
    }
  }
  return ids;
}

}  // namespace mm::service
