#include "jobs/model_publication.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace mm::service {
namespace {

namespace fs = std::filesystem;

std::string marker(const std::string& id) { return "Trained by training job `" + id + "`."; }

bool holds_card_of(const fs::path& folder, const std::string& id) {
  std::ifstream in(folder / "MODEL_CARD.md");
  std::stringstream text;
  text << in.rdbuf();
  return in && text.str().find(marker(id)) != std::string::npos;
}

}  // namespace

std::string job_model_card(const JobInfo& job, double training_seconds) {
  const JobSpec& s = job.spec;
  std::ostringstream card;
  card << "# " << (s.model_name.empty() ? "job-" + job.id : s.model_name) << "\n\n"
       << marker(job.id) << "\n\n"
       << "## Job\n\n"
       << "| field | value |\n| --- | --- |\n"
       << "| dataset | `" << s.dataset << "` |\n"
       << "| variant | " << (s.variant.empty() ? "(from config)" : s.variant) << " |\n"
       << "| config | " << (s.config_json.empty() ? "(none)" : "`" + s.config_json + "`") << " |\n"
       << "| iterations requested | " << (s.iterations > 0 ? std::to_string(s.iterations) : "the configuration's")
       << " |\n"
       << "| seed | " << s.seed << " |\n"
       << "| hidden | " << (s.hidden > 0 ? std::to_string(s.hidden) : "the configuration's") << " |\n"
       << "| batch | " << (s.batch > 0 ? std::to_string(s.batch) : "the configuration's") << " |\n"
       << "| iterations trained | " << job.progress.iteration << " of " << job.progress.total << " |\n"
       << "| training time | " << static_cast<long long>(training_seconds + 0.5) << " s |\n"
       << "| resumed after a restart | " << job.resumes << " times |\n\n"
       << "## Final losses\n\n| term | value |\n| --- | --- |\n";
  for (const auto& [name, value] : job.progress.losses) card << "| " << name << " | " << value << " |\n";
  card << "\nThe run's own provenance (command line, iterations, device) is in manifest.json.\n";
  return card.str();
}

void publish_job_model(const std::string& model_dir, const std::string& store, const std::string& name,
                       const JobInfo& job, const std::string& model_card) {
  const fs::path source(model_dir), destination = fs::path(store) / name;
  if (!fs::is_regular_file(source / "manifest.json")) {
    throw std::runtime_error("the run exported no model: " + (source / "manifest.json").string() + " is missing");
  }
  fs::create_directories(store);
  if (fs::exists(destination)) {
    if (holds_card_of(destination, job.id)) return;
    throw std::runtime_error("model_name: a model named \"" + name + "\" already exists in the store");
  }
  const fs::path temporary = fs::path(store) / (".job-" + job.id + ".tmp");
  try {
    fs::remove_all(temporary);
    fs::copy(source, temporary, fs::copy_options::recursive);
    std::ofstream card(temporary / "MODEL_CARD.md", std::ios::binary);
    card << model_card;
    card.close();
    if (!card) throw std::runtime_error("cannot write " + (temporary / "MODEL_CARD.md").string());
    // rename(2) of a folder onto an existing non-empty one fails, so a model
    // that appeared meanwhile is never replaced.
    fs::rename(temporary, destination);
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(temporary, ignored);
    throw;
  }
}

}  // namespace mm::service
