#include "server/jobs/job_spec_check.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "format/input_error.h"
#include "format/json_text.h"
#include "format/rig_folder_dataset.h"
#include "model/training_config.h"
#include "server/api/data_root_path.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void refuse(const std::string& field, const std::string& message) {
  throw ApiError(ErrorCode::kInvalidArgument, field, message);
}

std::string quoted(const std::string& value) { return nlohmann::json(value).dump(); }

// The magic and version of format/prepared_dataset.h: enough to tell a
// prepared dataset from anything else without loading it.
bool has_prepared_dataset_header(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  char header[12] = {};
  if (!in.read(header, sizeof header)) return false;
  if (std::memcmp(header, "MMPREP\r\n", 8) != 0) return false;
  const auto* v = reinterpret_cast<const unsigned char*>(header + 8);
  const uint32_t version = v[0] | (v[1] << 8) | (v[2] << 16) | (static_cast<uint32_t>(v[3]) << 24);
  return version == 1;
}

// S1 to S999999999: a number that fits an int, so that subjects sort by it.
bool is_subject_name(const std::string& name) { return std::regex_match(name, std::regex("S[0-9]{1,9}")); }

// A subject folder's motion files are <action>_<take>.txt.
bool holds_motion_files(const fs::path& folder) {
  static const std::regex motion_file("[a-z]+_[0-9]+\\.txt");
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    if (std::regex_match(entry.path().filename().string(), motion_file) && entry.is_regular_file(error)) return true;
  }
  return false;
}

std::vector<std::string> subjects_with_motion_files(const fs::path& folder) {
  std::vector<std::string> subjects;
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    if (is_subject_name(name) && entry.is_directory(error) && holds_motion_files(entry.path())) {
      subjects.push_back(name);
    }
  }
  std::sort(subjects.begin(), subjects.end(), [](const std::string& a, const std::string& b) {
    return std::stoi(a.substr(1)) < std::stoi(b.substr(1));
  });
  return subjects;
}

}  // namespace

const std::vector<std::string>& job_variants() {
  static const std::vector<std::string> variants{"S", "D", "DK", "DKG", "DKGM", "DKGMZ", "Seq2seq"};
  return variants;
}

JobDataset resolve_job_dataset(const std::string& data_root, const std::string& dataset) {
  if (dataset.empty()) {
    refuse("dataset", "dataset is empty, expected a prepared dataset file (.mmd), an H3.6M text tree or a folder of "
                      "animation files (.bvh, .glb, .gltf, .fbx) of one skeleton under the data root");
  }
  const fs::path root = canonical_data_root(data_root);
  const auto resolved = resolve_under_data_root(root, dataset, "dataset");
  if (!resolved) {
    refuse("dataset", "dataset " + quoted(dataset) + " lies outside the data root, expected a path under it");
  }
  const fs::path& path = *resolved;
  std::error_code error;
  JobDataset result;
  result.path = path;
  if (fs::is_regular_file(path, error)) {
    if (!has_prepared_dataset_header(path)) {
      refuse("dataset", "dataset " + quoted(dataset) +
                            " is not a prepared dataset file (no MMPREP header of version 1), expected a file "
                            "written by motion-manifold prepare or an H3.6M text tree");
    }
    result.prepared = true;
    return result;
  }
  if (!fs::is_directory(path, error)) {
    refuse("dataset", "dataset " + quoted(dataset) +
                          " does not exist, expected a prepared dataset file (.mmd) or an H3.6M text tree");
  }
  // The tool's own search (h36m_corpus.h): the folder itself, then
  // h3.6m/dataset and dataset below it.
  for (const fs::path& candidate : {path, path / "h3.6m" / "dataset", path / "dataset"}) {
    if (!fs::is_directory(candidate, error)) continue;
    auto subjects = subjects_with_motion_files(candidate);
    if (subjects.empty()) continue;
    if (std::all_of(subjects.begin(), subjects.end(), [](const std::string& s) { return s == "S5"; })) {
      refuse("dataset", "dataset " + quoted(dataset) +
                            " holds only the test subject S5, expected at least one training subject (S1, ...)");
    }
    result.path = candidate;
    result.subjects = std::move(subjects);
    return result;
  }
  std::vector<std::string> rig_files;
  try {
    rig_files = list_animation_files(path.string());
  } catch (const InputError&) {
    // Neither kind of folder: the message below says what was expected.
  }
  if (rig_files.size() == 1) {
    refuse("dataset", "dataset " + quoted(dataset) + " holds one animation file (" + rig_files.front() +
                          "), expected at least two (split by file into training and test)");
  }
  if (!rig_files.empty()) {
    try {
      check_one_file_per_name(rig_files, quoted(dataset));
    } catch (const InputError& e) {
      refuse("dataset", std::string("dataset ") + e.what());
    }
    result.rig_folder = true;
    return result;
  }
  refuse("dataset", "dataset " + quoted(dataset) +
                        " is a folder without H3.6M motion files or animation files, expected S1, S5, ... folders "
                        "holding <action>_<n>.txt files (in it, in h3.6m/dataset or in dataset below it) or .bvh, "
                        ".glb, .gltf or .fbx files of one skeleton");
}

// The spec's fields as overrides of its configuration: 0 is the
// configuration's, the seed is always the spec's.
ResolvedTrainConfig resolve_job_config(const JobSpec& spec) {
  TrainOverrides overrides;
  overrides.iterations = spec.iterations;
  overrides.hidden = spec.hidden;
  overrides.batch = spec.batch;
  overrides.seed = spec.seed;
  ResolvedTrainConfig resolved = resolve_train_config(spec.config_json, spec.variant, overrides, "config", "");
  resolved.config.dataset.clear();
  resolved.config.output_dir.clear();
  return resolved;
}

ResolvedTrainConfig check_job_spec(const JobSpec& spec) {
  const auto& variants = job_variants();
  // A configuration replaces the variant, which may then be left empty.
  const bool variant_needed = spec.config_json.empty() || !spec.variant.empty();
  if (variant_needed && std::find(variants.begin(), variants.end(), spec.variant) == variants.end()) {
    refuse("variant", "variant " + quoted(spec.variant) + " is unknown, expected one of S, D, DK, DKG, DKGM, DKGMZ, Seq2seq");
  }
  if (spec.iterations < 0 || spec.iterations > kMaxJobIterations) {
    refuse("iterations", "iterations " + std::to_string(spec.iterations) + " is out of range, expected 0 (the configuration's) to " +
                             std::to_string(kMaxJobIterations));
  }
  if (spec.hidden != 0 && (spec.hidden < kMinJobHidden || spec.hidden > kMaxJobHidden)) {
    refuse("hidden", "hidden " + std::to_string(spec.hidden) + " is out of range, expected 0 (the configuration's) or " +
                         std::to_string(kMinJobHidden) + " to " + std::to_string(kMaxJobHidden));
  }
  // Two clips at least: the MMD estimate needs two samples.
  if (spec.batch != 0 && (spec.batch < kMinJobBatch || spec.batch > kMaxJobBatch)) {
    refuse("batch", "batch " + std::to_string(spec.batch) + " is out of range, expected 0 (the configuration's) or " +
                        std::to_string(kMinJobBatch) + " to " + std::to_string(kMaxJobBatch));
  }
  // Read as the tool will read it, so that a bad configuration is refused
  // now, naming its field, and not after the dataset has been prepared. The
  // spec's own fields lie within the tool's ranges (the limits above), so
  // only the configuration can fail to resolve.
  ResolvedTrainConfig resolved;
  try {
    if (!spec.config_json.empty()) {
      const nlohmann::json document = parse_json_text(spec.config_json, "config");
      if (!document.is_object()) {
        refuse("config", "config is JSON " + std::string(document.type_name()) + ", expected an object");
      }
    }
    resolved = resolve_job_config(spec);
  } catch (const InputError& e) {
    refuse("config", e.what());
  }
  // The limits hold for the sizes the configuration sets (those the spec
  // sets were checked above); a variant's defaults lie within them.
  const TrainConfig& config = resolved.config;
  if (spec.iterations == 0 && config.iterations > kMaxJobIterations) {
    refuse("config", "config: iterations: " + std::to_string(config.iterations) + " is out of range, expected at most " +
                         std::to_string(kMaxJobIterations));
  }
  if (spec.hidden == 0 && (config.model.hidden < kMinJobHidden || config.model.hidden > kMaxJobHidden)) {
    refuse("config", "config: model.hidden: " + std::to_string(config.model.hidden) + " is out of range, expected " +
                         std::to_string(kMinJobHidden) + " to " + std::to_string(kMaxJobHidden));
  }
  if (spec.batch == 0 && config.batch > kMaxJobBatch) {
    refuse("config", "config: batch: " + std::to_string(config.batch) + " is out of range, expected at most " +
                         std::to_string(kMaxJobBatch));
  }
  if (!spec.model_name.empty()) {
    static const std::regex name("[A-Za-z0-9._-]{1,64}");
    if (!std::regex_match(spec.model_name, name) || spec.model_name == "." || spec.model_name == ".." ||
        spec.model_name[0] == '.') {
      refuse("model_name", "model_name " + quoted(spec.model_name) +
                               " is not a model name, expected 1 to 64 of A-Z a-z 0-9 . _ - not starting with a dot "
                               "(or empty for job-<id>)");
    }
    // An unnamed job publishes job-<its id>: a name of that form could be
    // taken by one and then refused to the other after all its training.
    if (spec.model_name.rfind("job-", 0) == 0) {
      refuse("model_name", "model_name " + quoted(spec.model_name) +
                               " starts with \"job-\", which names the models of jobs submitted without a model_name; "
                               "expected another name");
    }
  }
  return resolved;
}

}  // namespace mm::service
