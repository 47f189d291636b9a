// Publishing a finished job's model into the model store: the run's exported
// model folder is copied to a hidden staging folder inside the store
// (".job-<id>.tmp", on the same file system) with a MODEL_CARD.md saying
// which job trained it, then renamed to its name, so that the store never
// shows a half-copied model.
//
// Thread safety: free functions without shared state; two stagings must
// not use the same job id at once.
#pragma once

#include <string>
#include <vector>

#include "server/api/api_types.h"

namespace mm::service {

// The model card of a job's model: the job, its spec, the values of the
// configuration it trained (job.resolved_config), iterations, training time
// and final losses (Markdown). Throws std::runtime_error for a record
// without a configuration.
std::string job_model_card(const JobInfo& job, double training_seconds);

// A publication has two halves (see training_jobs.cpp): staging, which the
// store's readers do not see, and the rename that makes the model appear,
// before the job's record is committed; a commit that loses to a cancel
// withdraws the model again.

// Copies `model_dir` to the job's hidden folder <store>/.job-<id>.tmp with
// its model card. Returns false, staging nothing, when <store>/<name>
// already holds this job's model card (published before a crash).
// std::runtime_error when the model folder lacks manifest.json, the name is
// taken by another model, or copying fails (the staged folder is then
// removed).
bool stage_job_model(const std::string& model_dir, const std::string& store, const std::string& name,
                     const JobInfo& job, const std::string& model_card);

// Renames the job's staged folder to <store>/<name>. A destination that
// already holds this job's model card (another replica's recovery renamed
// it) counts as published. std::runtime_error otherwise, the staged folder
// left in place.
void commit_staged_model(const std::string& store, const std::string& name, const std::string& job_id);

// Takes the job's published model <store>/<name> out of the store: renamed
// back to its staging folder (so it disappears at once), then removed. A
// folder of that name without this job's model card is left alone.
void withdraw_job_model(const std::string& store, const std::string& name, const std::string& job_id);

// Removes the job's staged folder, if there is one.
void discard_staged_model(const std::string& store, const std::string& job_id);

// The ids of the jobs with a staged folder in the store.
std::vector<std::string> staged_job_ids(const std::string& store);

}  // namespace mm::service
