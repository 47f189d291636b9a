// Submission checks of a training job's spec: each refusal is an ApiError
// naming the field as the wire spells it ("dataset", "variant", ...), with
// the value and what was expected, so that a bad job fails when it is
// submitted and not minutes later in the worker.
//
// Torch-free: a prepared dataset is recognised by its magic bytes and
// version (format/prepared_dataset.h), a text tree by its S*/<action>_<n>.txt
// files, a rig's folder by its animation files (.bvh, .glb, .gltf, .fbx),
// without reading any. Thread safe (no shared state).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "api/api_types.h"
#include "training_config.h"

namespace mm::service {

// A job's dataset, resolved to an absolute path inside the data root.
struct JobDataset {
  std::filesystem::path path;  // the .mmd file, or the folder holding S1, S5, ...
  bool prepared = false;       // a prepared dataset file, not a text tree
  // A folder of animation files of one skeleton (format/rig_folder_dataset.h),
  // prepared with the default split by file and the unit detected.
  bool rig_folder = false;
  // A text tree's subjects that hold motion files, sorted (S1, S5, S6, ...).
  std::vector<std::string> subjects;
};

// Resolves `dataset` (relative to `data_root`, or absolute) with `..` and
// symbolic links followed, and checks that it lies under the data root and
// is a prepared dataset file, an H3.6M text tree with at least one
// training subject (any subject but the test subject S5), or a folder
// holding at least two animation files of distinct names without their
// extensions (one for training, one for testing; their content is checked
// when the job prepares them). ApiError INVALID_ARGUMENT with field
// "dataset" otherwise.
JobDataset resolve_job_dataset(const std::string& data_root, const std::string& dataset);

// The limits of a job's size, whether the spec or its configuration sets it.
constexpr int64_t kMaxJobIterations = 10'000'000;
constexpr int kMinJobHidden = 8, kMaxJobHidden = 4096;
constexpr int kMaxJobBatch = 1024;

// Checks the spec's other fields: variant (one of S D DK DKG DKGM DKGMZ
// Seq2seq, unless a configuration replaces it), iterations 0 (the
// configuration's) to kMaxJobIterations, hidden 0 or kMinJobHidden to
// kMaxJobHidden, batch 0 or 2 to kMaxJobBatch, config (empty, or a training
// configuration as the tool reads it, whose sizes keep the same limits) and
// the form of model_name ([A-Za-z0-9._-]{1,64}, not starting with a dot or
// with "job-", or empty). ApiError INVALID_ARGUMENT naming the field
// otherwise.
void check_job_spec(const JobSpec& spec);

// The training configuration a checked spec trains, whole: its config (or
// its variant's defaults) with its iterations, hidden and batch where they
// are not 0 and its seed, by the rule the tool's `train` flags follow
// (resolve_train_config). model.pose_dims come from the dataset unless
// config gives them; dataset and output_dir are empty (the server gives the
// run its own). Throws InputError for a spec that check_job_spec refuses.
ResolvedTrainConfig resolve_job_config(const JobSpec& spec);

// The same as JSON text (to_json_text of a ResolvedTrainConfig): what a job
// record keeps.
std::string resolved_job_config_json(const JobSpec& spec);

// The Table 1 variants the tool trains.
const std::vector<std::string>& job_variants();

}  // namespace mm::service
