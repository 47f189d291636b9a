// Publishing a finished job's model into the model store: the run's exported
// model folder is copied to a hidden temporary folder inside the store
// (".job-<id>.tmp", on the same file system) with a MODEL_CARD.md saying
// which job trained it, then renamed to its name, so that the store never
// shows a half-copied model.
//
// Thread safety: free functions without shared state; two publications must
// not use the same job id at once.
#pragma once

#include <string>

#include "core/api_types.h"

namespace mm::service {

// The model card of a job's model: the job, its spec, iterations, training
// time and final losses (Markdown).
std::string job_model_card(const JobInfo& job, double training_seconds);

// Copies `model_dir` to <store>/<name> as above. A folder of that name that
// already holds this job's model card (a publication whose record was not
// written before a crash) counts as published. std::runtime_error when the
// model folder lacks manifest.json, the name is taken by another model, or
// copying fails (the temporary folder is then removed).
void publish_job_model(const std::string& model_dir, const std::string& store, const std::string& name,
                       const JobInfo& job, const std::string& model_card);

}  // namespace mm::service
