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

#include "model/training_config.h"
#include "server/api/api_types.h"

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

// The limits of a job's size, whether the spec or its configuration sets
// it: the tool's ranges (training_config.h), narrowed where a job of a
// server that others share must be. The upper bounds keep one job's memory
// and time within such a server's: at the tool's kMaxTrainHidden (65536) a
// GRU's recurrent weights alone are 3 x 65536^2 = 12.9e9 values (51 GB of
// float32), at 4096 they are 50e6 (201 MB). The lower bound of hidden, 8,
// is the service's since jobs were added, kept so that no request changes
// meaning; the tool's 1 is left to its own experiments.
constexpr int64_t kMaxJobIterations = 10'000'000;
constexpr int kMinJobHidden = 8, kMaxJobHidden = 4096;
constexpr int kMinJobBatch = kMinTrainBatch, kMaxJobBatch = 1024;
static_assert(kMaxJobIterations <= kMaxTrainIterations, "a job's iterations lie within the tool's");
static_assert(kMinJobHidden >= kMinTrainHidden && kMaxJobHidden <= kMaxTrainHidden, "a job's hidden lies within the tool's");
static_assert(kMaxJobBatch <= kMaxTrainBatch, "a job's batch lies within the tool's");

// Checks the spec and resolves it, once, into the training configuration
// the job trains (resolve_job_config), which it returns: variant (one of S
// D DK DKG DKGM DKGMZ Seq2seq, unless a configuration replaces it),
// iterations 0 (the configuration's) to kMaxJobIterations, hidden 0 or
// kMinJobHidden to kMaxJobHidden, batch 0 or kMinJobBatch to kMaxJobBatch,
// config (empty, or a training configuration as the tool reads it), the
// resolved configuration's sizes within the same limits where the spec
// leaves them to it, and the form of model_name ([A-Za-z0-9._-]{1,64}, not
// starting with a dot or with "job-", or empty). ApiError INVALID_ARGUMENT
// naming the field otherwise.
ResolvedTrainConfig check_job_spec(const JobSpec& spec);

// The training configuration a spec trains, whole: its config (or its
// variant's defaults) with its iterations, hidden and batch where they are
// not 0 and its seed, by the rule the tool's `train` flags follow
// (resolve_train_config). model.pose_dims come from the dataset unless
// config gives them; dataset and output_dir are empty (the server gives the
// run its own). Used by check_job_spec at submission and, for a record
// stored before submissions were resolved, by the record's reader
// (job_record_json.h). Throws InputError for a spec that does not resolve.
ResolvedTrainConfig resolve_job_config(const JobSpec& spec);

// The Table 1 variants the tool trains.
const std::vector<std::string>& job_variants();

}  // namespace mm::service
