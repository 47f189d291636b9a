// The JSON text forms of a training job's record, shared by the job stores
// (spec and progress are stored as JSON text columns: read and written
// whole, never queried by part) and by logs and the model card.
//
// Thread safety: free functions without shared state.
// Errors: the *_from_* readers throw std::runtime_error (or nlohmann's
// exceptions, which derive from std::exception) for malformed text.
#pragma once

#include <optional>
#include <string>

#include "server/api/api_types.h"

namespace mm::service {

// The record as JSON (every field), for logs, the model card and for telling
// whether a record changed.
std::string job_to_json_text(const JobInfo& job);
std::string spec_to_json_text(const JobSpec& spec);
JobSpec spec_from_json_text(const std::string& text);
// The spec column of a stored record: the spec's fields and, under
// "resolved_config", the configuration it resolved to at submission (its
// JSON text as a string).
std::string stored_spec_to_json_text(const JobInfo& job);
// Reads that column into job.spec and job.resolved_config. A record stored
// by a server that did not resolve configurations has none (or "", that of
// a record made without one): it is resolved now from its spec
// (resolve_job_config), the one place such a record is brought up to date;
// one whose spec no longer resolves, or whose configuration does not read,
// is left without (the job then fails when it runs, saying so).
void stored_spec_from_json_text(const std::string& text, JobInfo& job);
// Sets job.resolved_config and, from it, the JSON text the wire shows
// (job.resolved_config_json): the two never differ.
void set_resolved_config(JobInfo& job, std::optional<ResolvedTrainConfig> config);
std::string progress_to_json_text(const JobProgress& progress);
JobProgress progress_from_json_text(const std::string& text);
// The inverse of job_state_name().
JobState job_state_from_name(const std::string& name);

}  // namespace mm::service
