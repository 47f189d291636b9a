#include "server/translation/proto_translation.h"

namespace mm::service::proto_translation {

namespace {

template <typename Repeated, typename T>
void copy_into(const std::vector<T>& from, Repeated* to) {
  to->Reserve(static_cast<int>(from.size()));
  to->Add(from.begin(), from.end());
}

}  // namespace

// ---- wire -> core

Motion to_api(const v1::Motion& motion) {
  Motion out;
  out.frames = motion.frames();
  out.columns = motion.columns();
  out.frame_rate = motion.frame_rate();
  out.layout = motion.layout();
  out.values.assign(motion.values().begin(), motion.values().end());
  out.root = motion.root();
  return out;
}

Code to_api(const v1::Code& code) { return Code(code.values().begin(), code.values().end()); }

MotionOrCode to_api(const v1::MotionOrCode& either) {
  // Neither set stays neither: the core names the field.
  MotionOrCode out;
  if (either.has_motion()) out.motion = to_api(either.motion());
  if (either.has_code()) out.code = to_api(either.code());
  return out;
}

EncodeRequest to_api(const v1::EncodeRequest& request) {
  EncodeRequest out;
  out.model = request.model();
  out.motions.reserve(request.motions_size());
  for (const auto& motion : request.motions()) out.motions.push_back(to_api(motion));
  return out;
}

DecodeRequest to_api(const v1::DecodeRequest& request) {
  DecodeRequest out;
  out.model = request.model();
  out.codes.reserve(request.codes_size());
  for (const auto& code : request.codes()) out.codes.push_back(to_api(code));
  out.decoder = request.decoder();
  out.plant_feet = request.plant_feet();
  return out;
}

SampleRequest to_api(const v1::SampleRequest& request) {
  SampleRequest out;
  if (request.count() != 0) out.count = request.count();  // 0 is proto3's "unset"
  out.seed = request.seed();
  out.decoder = request.decoder();
  out.plant_feet = request.plant_feet();
  out.model = request.model();
  return out;
}

InterpolateRequest to_api(const v1::InterpolateRequest& request) {
  InterpolateRequest out;
  out.model = request.model();
  out.from = to_api(request.from());
  out.to = to_api(request.to());
  if (request.steps() != 0) out.steps = request.steps();
  if (!request.method().empty()) out.method = request.method();
  out.decoder = request.decoder();
  out.plant_feet = request.plant_feet();
  return out;
}

AnalogyRequest to_api(const v1::AnalogyRequest& request) {
  AnalogyRequest out;
  out.model = request.model();
  out.a = to_api(request.a());
  out.b = to_api(request.b());
  out.c = to_api(request.c());
  out.decoder = request.decoder();
  out.plant_feet = request.plant_feet();
  return out;
}

DenoiseRequest to_api(const v1::DenoiseRequest& request) {
  DenoiseRequest out;
  out.model = request.model();
  out.motions.reserve(request.motions_size());
  for (const auto& motion : request.motions()) out.motions.push_back(to_api(motion));
  out.decoder = request.decoder();
  out.zeros_are_missing = request.zeros_are_missing();
  out.means_are_missing = request.means_are_missing();
  if (request.iterations() != 0) out.iterations = request.iterations();
  out.keep_observed = request.keep_observed();
  return out;
}

JoinClipsRequest to_api(const v1::JoinClipsRequest& request) {
  JoinClipsRequest out;
  out.model = request.model();
  out.a = to_api(request.a());
  out.b = to_api(request.b());
  if (request.transition_seconds() != 0) out.transition_seconds = request.transition_seconds();
  if (!request.method().empty()) out.method = request.method();
  out.decoder = request.decoder();
  return out;
}

JobSpec to_api(const v1::JobSpec& spec) {
  JobSpec out;
  out.dataset = spec.dataset();
  if (!spec.variant().empty()) out.variant = spec.variant();
  out.config_json = spec.config_json();
  out.iterations = spec.iterations();
  out.seed = spec.seed();
  out.hidden = spec.hidden();
  out.batch = spec.batch();
  out.model_name = spec.model_name();
  return out;
}

UploadClipRequest to_api(const v1::UploadClipRequest& request) {
  UploadClipRequest out;
  out.path = request.path();
  out.content = request.content();
  return out;
}

ReadClipRequest to_api(const v1::ReadClipRequest& request) {
  ReadClipRequest out;
  out.model = request.model();
  out.path = request.path();
  out.start = request.start();
  out.whole = request.whole();
  return out;
}

// ---- core -> wire

void to_wire(const Motion& motion, v1::Motion* out) {
  out->Clear();
  out->set_frames(motion.frames);
  out->set_columns(motion.columns);
  out->set_frame_rate(motion.frame_rate);
  out->set_layout(motion.layout);
  copy_into(motion.values, out->mutable_values());
  out->set_root(motion.root);
  out->mutable_contacts()->Add(motion.contacts.begin(), motion.contacts.end());
}

void to_wire(const Code& code, v1::Code* out) {
  out->Clear();
  copy_into(code, out->mutable_values());
}

void to_wire(const AnsweredBy& answered_by, v1::AnsweredBy* out) {
  out->Clear();
  out->set_model(answered_by.model);
  out->set_version(answered_by.version);
}

void to_wire(const EncodeReply& reply, v1::EncodeReply* out) {
  out->Clear();
  to_wire(reply.answered_by, out->mutable_answered_by());
  out->mutable_codes()->Reserve(static_cast<int>(reply.codes.size()));
  for (const auto& code : reply.codes) to_wire(code, out->add_codes());
}

void to_wire(const MotionsReply& reply, v1::MotionsReply* out) {
  out->Clear();
  to_wire(reply.answered_by, out->mutable_answered_by());
  out->mutable_motions()->Reserve(static_cast<int>(reply.motions.size()));
  for (const auto& motion : reply.motions) to_wire(motion, out->add_motions());
  out->mutable_codes()->Reserve(static_cast<int>(reply.codes.size()));
  for (const auto& code : reply.codes) to_wire(code, out->add_codes());
}

void to_wire(const JoinClipsReply& reply, v1::JoinClipsReply* out) {
  out->Clear();
  to_wire(reply.answered_by, out->mutable_answered_by());
  to_wire(reply.motion, out->mutable_motion());
  out->set_transition_first_frame(reply.transition_first_frame);
  out->set_transition_last_frame(reply.transition_last_frame);
}

void to_wire(const ModelInfo& info, v1::ModelInfo* out) {
  out->Clear();
  out->set_name(info.name);
  out->set_version(info.version);
  out->set_active(info.active);
  out->set_loaded(info.loaded);
  out->set_variant(info.variant);
  out->set_hidden(info.hidden);
  out->set_latent(info.latent);
  out->set_frames(info.frames);
  out->set_columns(info.columns);
  out->set_frame_rate(info.frame_rate);
  out->set_layout(info.layout);
  for (const auto& decoder : info.decoders) out->add_decoders(decoder);
  out->set_load_seconds(info.load_seconds);
  out->set_precision(info.precision);
  out->set_trajectory(info.trajectory);
  for (const auto& foot : info.feet) out->add_feet(foot);
  out->set_provenance_json(info.provenance_json);
  out->set_evaluation_json(info.evaluation_json);
  out->set_model_card(info.model_card);
  out->set_skeleton_json(info.skeleton_json);
}

void to_wire(const ClipFile& clip, v1::ClipFile* out) {
  out->Clear();
  out->set_path(clip.path);
  out->set_format(clip.format);
  out->set_size_bytes(clip.size_bytes);
  out->set_uploaded(clip.uploaded);
}

void to_wire(const ListClipsReply& reply, v1::ListClipsReply* out) {
  out->Clear();
  out->mutable_clips()->Reserve(static_cast<int>(reply.clips.size()));
  for (const auto& clip : reply.clips) to_wire(clip, out->add_clips());
  out->set_truncated(reply.truncated);
}

void to_wire(const ReadClipReply& reply, v1::ReadClipReply* out) {
  out->Clear();
  out->set_path(reply.path);
  out->set_format(reply.format);
  out->set_start(reply.start);
  out->set_file_frames(reply.file_frames);
  out->set_file_frame_rate(reply.file_frame_rate);
  out->set_last_start(reply.last_start);
  to_wire(reply.motion, out->mutable_motion());
}

void to_wire(const JobSpec& spec, v1::JobSpec* out) {
  out->Clear();
  out->set_dataset(spec.dataset);
  out->set_variant(spec.variant);
  out->set_config_json(spec.config_json);
  out->set_iterations(spec.iterations);
  out->set_seed(spec.seed);
  out->set_hidden(spec.hidden);
  out->set_batch(spec.batch);
  out->set_model_name(spec.model_name);
}

void to_wire(const JobProgress& progress, v1::JobProgress* out) {
  out->Clear();
  out->set_iteration(progress.iteration);
  out->set_total(progress.total);
  out->mutable_losses()->insert(progress.losses.begin(), progress.losses.end());
  out->set_iterations_per_second(progress.iterations_per_second);
  out->set_eta_seconds(progress.eta_seconds);
}

void to_wire(const JobInfo& info, v1::Job* out) {
  out->Clear();
  out->set_id(info.id);
  to_wire(info.spec, out->mutable_spec());
  out->set_state(job_state_name(info.state));
  to_wire(info.progress, out->mutable_progress());
  out->set_error(info.error);
  out->set_published_model(info.published_model);
  out->set_created_at(info.created_at);
  out->set_started_at(info.started_at);
  out->set_finished_at(info.finished_at);
  out->set_resumes(info.resumes);
  out->set_resolved_config_json(info.resolved_config_json);
}

TakeRequest to_api(const v1::TakeHeader& header) {
  TakeRequest request;
  request.model = header.model();
  request.frame_rate = header.frame_rate();
  request.columns = header.columns();
  request.layout = header.layout();
  request.decoder = header.decoder();
  request.hop_seconds = header.hop_seconds();
  request.blend = header.blend();
  request.at_model_rate = header.at_model_rate();
  request.zeros_are_missing = header.zeros_are_missing();
  request.means_are_missing = header.means_are_missing();
  request.iterations = header.iterations();
  request.keep_observed = header.keep_observed();
  request.gap_fill = header.gap_fill();
  request.root = header.root();
  return request;
}

TakeWindow to_api(const v1::TakeWindow& window) {
  TakeWindow out;
  out.start_seconds = window.start_seconds();
  out.start_frame = window.start_frame();
  out.code = to_api(window.code());
  return out;
}

DecodeTrackRequest to_api(const v1::DecodeTrackRequest& request) {
  DecodeTrackRequest out;
  out.model = request.model();
  for (const auto& window : request.windows()) out.windows.push_back(to_api(window));
  out.frame_rate = request.frame_rate();
  out.frames = request.frames();
  out.decoder = request.decoder();
  out.blend = request.blend();
  return out;
}

void to_wire(const TakeWindow& window, v1::TakeWindow* out) {
  out->set_start_seconds(window.start_seconds);
  out->set_start_frame(window.start_frame);
  to_wire(window.code, out->mutable_code());
}

void to_wire(const TakeReplyStart& start, v1::TakeOutputHeader* out) {
  to_wire(start.answered_by, out->mutable_answered_by());
  out->set_frame_rate(start.frame_rate);
  out->set_columns(start.columns);
  out->set_layout(start.layout);
}

void to_wire(const TakeSummary& summary, v1::CodeTrack* out) {
  out->set_frames(summary.input_frames);
  out->set_frame_rate(summary.input_rate);
  out->set_window_seconds(summary.window_seconds);
  out->set_hop_seconds(summary.hop_seconds);
}

void to_wire(const TakeSummary& summary, v1::TakeSummary* out) {
  out->set_frames(summary.output_frames);
  out->set_input_frames(summary.input_frames);
  out->set_mean_error_mm(summary.mean_error_mm);
  out->set_max_error_mm(summary.max_error_mm);
  out->set_window_seconds(summary.window_seconds);
  out->set_hop_seconds(summary.hop_seconds);
  out->set_gap_windows_fitted(summary.gap_windows_fitted);
  out->set_gaps_fitted(summary.gaps_fitted);
  out->set_gaps_over_fit_limit(summary.gaps_over_fit_limit);
}

}  // namespace mm::service::proto_translation
