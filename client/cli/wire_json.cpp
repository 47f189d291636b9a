#include "wire_json.h"

namespace mm::client {
namespace {

json code_json(const v1::Code& code) { return std::vector<float>(code.values().begin(), code.values().end()); }

json motion_json(const v1::Motion& motion) {
  return {{"frames", motion.frames()},
          {"columns", motion.columns()},
          {"frame_rate", motion.frame_rate()},
          {"layout", motion.layout()},
          {"values", std::vector<float>(motion.values().begin(), motion.values().end())}};
}

json motion_or_code_json(const v1::MotionOrCode& input) {
  if (input.has_motion()) return {{"motion", motion_json(input.motion())}};
  if (input.has_code()) return {{"code", code_json(input.code())}};
  return json::object();  // neither: the server names the field
}

json answered_by_json(const v1::AnsweredBy& answered_by) {
  return {{"model", answered_by.model()}, {"version", answered_by.version()}};
}

// A JSON-text field as the object it holds ("{}" when empty or unreadable,
// which the server never sends).
json embedded(const std::string& text) {
  if (text.empty()) return json::object();
  auto parsed = json::parse(text, nullptr, false);
  return parsed.is_discarded() ? json(text) : parsed;
}

std::string embedded_text(const json& body, const char* key) {
  if (!body.contains(key) || body[key].is_null()) return "";
  return body[key].is_string() ? body[key].get<std::string>() : body[key].dump();
}

void read_code(const json& values, v1::Code* code) {
  for (const auto& v : values) code->add_values(v.get<float>());
}

void read_motion(const json& body, v1::Motion* motion) {
  motion->set_frames(body.at("frames").get<int>());
  motion->set_columns(body.at("columns").get<int>());
  motion->set_frame_rate(body.at("frame_rate").get<double>());
  motion->set_layout(body.value("layout", ""));
  auto* values = motion->mutable_values();
  values->Reserve(static_cast<int>(body.at("values").size()));
  for (const auto& v : body.at("values")) values->Add(v.get<float>());
}

void read_answered_by(const json& body, v1::AnsweredBy* answered_by) {
  if (!body.contains("answered_by")) return;
  answered_by->set_model(body["answered_by"].value("model", ""));
  answered_by->set_version(body["answered_by"].value("version", ""));
}

// A 64-bit integer, which proto3's JSON (and the server) may write as a string.
template <typename Int>
Int integer(const json& body, const char* key) {
  if (!body.contains(key) || body[key].is_null()) return 0;
  if (body[key].is_string()) return static_cast<Int>(std::stoll(body[key].get<std::string>()));
  return body[key].get<Int>();
}

json take_window_json(const v1::TakeWindow& window) {
  return {{"start_seconds", window.start_seconds()},
          {"start_frame", window.start_frame()},
          {"code", code_json(window.code())}};
}

json take_windows_json(const google::protobuf::RepeatedPtrField<v1::TakeWindow>& windows) {
  json out = json::array();
  for (const auto& w : windows) out.push_back(take_window_json(w));
  return out;
}

void read_take_windows(const json& body, google::protobuf::RepeatedPtrField<v1::TakeWindow>* windows) {
  if (!body.contains("windows")) return;
  for (const auto& w : body.at("windows")) {
    v1::TakeWindow* window = windows->Add();
    window->set_start_seconds(w.at("start_seconds").get<double>());
    window->set_start_frame(integer<int64_t>(w, "start_frame"));
    read_code(w.at("code"), window->mutable_code());
  }
}

}  // namespace

json to_json(const v1::EncodeRequest& request) {
  json motions = json::array();
  for (const auto& m : request.motions()) motions.push_back(motion_json(m));
  return {{"model", request.model()}, {"motions", std::move(motions)}};
}

json to_json(const v1::DecodeRequest& request) {
  json codes = json::array();
  for (const auto& c : request.codes()) codes.push_back(code_json(c));
  return {{"model", request.model()}, {"codes", std::move(codes)}, {"decoder", request.decoder()}};
}

json to_json(const v1::SampleRequest& request) {
  json out = {{"model", request.model()}, {"seed", request.seed()}, {"decoder", request.decoder()}};
  if (request.count() != 0) out["count"] = request.count();
  return out;
}

json to_json(const v1::InterpolateRequest& request) {
  json out = {{"model", request.model()},
              {"from", motion_or_code_json(request.from())},
              {"to", motion_or_code_json(request.to())},
              {"decoder", request.decoder()}};
  if (request.steps() != 0) out["steps"] = request.steps();
  if (!request.method().empty()) out["method"] = request.method();
  return out;
}

json to_json(const v1::AnalogyRequest& request) {
  return {{"model", request.model()},
          {"a", motion_or_code_json(request.a())},
          {"b", motion_or_code_json(request.b())},
          {"c", motion_or_code_json(request.c())},
          {"decoder", request.decoder()}};
}

json to_json(const v1::DenoiseRequest& request) {
  json motions = json::array();
  for (const auto& m : request.motions()) motions.push_back(motion_json(m));
  json out = {{"model", request.model()},
              {"motions", std::move(motions)},
              {"decoder", request.decoder()},
              {"zeros_are_missing", request.zeros_are_missing()},
              {"means_are_missing", request.means_are_missing()},
              {"keep_observed", request.keep_observed()}};
  if (request.iterations() != 0) out["iterations"] = request.iterations();
  return out;
}

json to_json(const v1::JobSpec& spec) {
  json out = {{"dataset", spec.dataset()}, {"iterations", spec.iterations()}, {"seed", spec.seed()},
              {"hidden", spec.hidden()},   {"batch", spec.batch()},           {"model_name", spec.model_name()}};
  if (!spec.variant().empty()) out["variant"] = spec.variant();
  if (!spec.config_json().empty()) out["config"] = embedded(spec.config_json());
  return out;
}

json to_json(const v1::EncodeReply& reply) {
  json codes = json::array();
  for (const auto& c : reply.codes()) codes.push_back(code_json(c));
  return {{"answered_by", answered_by_json(reply.answered_by())}, {"codes", std::move(codes)}};
}

json to_json(const v1::MotionsReply& reply) {
  json motions = json::array(), codes = json::array();
  for (const auto& m : reply.motions()) motions.push_back(motion_json(m));
  for (const auto& c : reply.codes()) codes.push_back(code_json(c));
  return {{"answered_by", answered_by_json(reply.answered_by())},
          {"motions", std::move(motions)},
          {"codes", std::move(codes)}};
}

json to_json(const v1::ModelInfo& model) {
  return {{"name", model.name()},
          {"version", model.version()},
          {"active", model.active()},
          {"loaded", model.loaded()},
          {"variant", model.variant()},
          {"hidden", model.hidden()},
          {"latent", model.latent()},
          {"frames", model.frames()},
          {"columns", model.columns()},
          {"frame_rate", model.frame_rate()},
          {"layout", model.layout()},
          {"decoders", std::vector<std::string>(model.decoders().begin(), model.decoders().end())},
          {"load_seconds", model.load_seconds()},
          {"provenance", embedded(model.provenance_json())},
          {"evaluation", embedded(model.evaluation_json())},
          {"model_card", model.model_card()},
          {"skeleton", embedded(model.skeleton_json())}};
}

json to_json(const v1::ListModelsReply& reply) {
  json models = json::array();
  for (const auto& m : reply.models()) models.push_back(to_json(m));
  return {{"models", std::move(models)}};
}

json to_json(const v1::ClipFile& clip) {
  return {{"path", clip.path()}, {"format", clip.format()}, {"size_bytes", clip.size_bytes()}, {"uploaded", clip.uploaded()}};
}

json to_json(const v1::ListClipsReply& reply) {
  json clips = json::array();
  for (const auto& c : reply.clips()) clips.push_back(to_json(c));
  return {{"clips", std::move(clips)}, {"truncated", reply.truncated()}};
}

json to_json(const v1::ReadClipReply& reply) {
  return {{"path", reply.path()},
          {"format", reply.format()},
          {"start", reply.start()},
          {"file_frames", reply.file_frames()},
          {"file_frame_rate", reply.file_frame_rate()},
          {"last_start", reply.last_start()},
          {"motion", motion_json(reply.motion())}};
}

json to_json(const v1::Job& job) {
  const auto& p = job.progress();
  json losses = json::object();
  for (const auto& [name, value] : p.losses()) losses[name] = value;
  return {{"id", job.id()},
          {"spec", to_json(job.spec())},
          {"state", job.state()},
          {"progress",
           {{"iteration", p.iteration()},
            {"total", p.total()},
            {"losses", std::move(losses)},
            {"iterations_per_second", p.iterations_per_second()},
            {"eta_seconds", p.eta_seconds()}}},
          {"error", job.error()},
          {"published_model", job.published_model()},
          {"created_at", job.created_at()},
          {"started_at", job.started_at()},
          {"finished_at", job.finished_at()},
          {"resumes", job.resumes()},
          {"resolved_config", embedded(job.resolved_config_json())}};
}

json to_json(const v1::ListJobsReply& reply) {
  json jobs = json::array();
  for (const auto& j : reply.jobs()) jobs.push_back(to_json(j));
  return {{"jobs", std::move(jobs)}};
}

json to_json(const v1::DecodeTrackRequest& request) {
  json windows = json::array();
  for (const auto& w : request.windows()) {
    windows.push_back({{"start_seconds", w.start_seconds()}, {"code", code_json(w.code())}});
  }
  json body = {{"model", request.model()}, {"windows", std::move(windows)}, {"frame_rate", request.frame_rate()},
               {"frames", request.frames()}};
  if (!request.decoder().empty()) body["decoder"] = request.decoder();
  if (!request.blend().empty()) body["blend"] = request.blend();
  return body;
}

json to_json(const v1::CodeTrack& track) {
  return {{"answered_by", answered_by_json(track.answered_by())},
          {"frames", track.frames()},
          {"frame_rate", track.frame_rate()},
          {"window_seconds", track.window_seconds()},
          {"hop_seconds", track.hop_seconds()},
          {"windows", take_windows_json(track.windows())}};
}

json to_json(const v1::TakeSummary& summary) {
  return {{"summary",
           {{"frames", summary.frames()},
            {"input_frames", summary.input_frames()},
            {"mean_error_mm", summary.mean_error_mm()},
            {"max_error_mm", summary.max_error_mm()},
            {"window_seconds", summary.window_seconds()},
            {"hop_seconds", summary.hop_seconds()}}},
          {"windows", take_windows_json(summary.windows())}};
}

v1::CodeTrack code_track_from_json(const json& body) {
  v1::CodeTrack track;
  read_answered_by(body, track.mutable_answered_by());
  track.set_frames(integer<int64_t>(body, "frames"));
  track.set_frame_rate(body.value("frame_rate", 0.0));
  track.set_window_seconds(body.value("window_seconds", 0.0));
  track.set_hop_seconds(body.value("hop_seconds", 0.0));
  read_take_windows(body, track.mutable_windows());
  return track;
}

v1::TakeOutputHeader take_header_from_json(const json& body) {
  v1::TakeOutputHeader header;
  read_answered_by(body, header.mutable_answered_by());
  header.set_frame_rate(body.at("frame_rate").get<double>());
  header.set_columns(body.at("columns").get<int>());
  header.set_layout(body.value("layout", ""));
  return header;
}

v1::FrameChunk take_frames_from_json(const json& body) {
  v1::FrameChunk chunk;
  chunk.set_frames(body.at("frames").get<int32_t>());
  auto* values = chunk.mutable_values();
  values->Reserve(static_cast<int>(body.at("values").size()));
  for (const auto& v : body.at("values")) values->Add(v.get<float>());
  if (body.contains("error_mm")) {
    for (const auto& e : body.at("error_mm")) chunk.add_error_mm(e.get<float>());
  }
  return chunk;
}

v1::TakeSummary take_summary_from_json(const json& body) {
  v1::TakeSummary summary;
  const json& s = body.at("summary");
  summary.set_frames(integer<int64_t>(s, "frames"));
  summary.set_input_frames(integer<int64_t>(s, "input_frames"));
  summary.set_mean_error_mm(s.value("mean_error_mm", 0.0));
  summary.set_max_error_mm(s.value("max_error_mm", 0.0));
  summary.set_window_seconds(s.value("window_seconds", 0.0));
  summary.set_hop_seconds(s.value("hop_seconds", 0.0));
  read_take_windows(body, summary.mutable_windows());
  return summary;
}

v1::EncodeReply encode_reply_from_json(const json& body) {
  v1::EncodeReply reply;
  read_answered_by(body, reply.mutable_answered_by());
  for (const auto& c : body.value("codes", json::array())) read_code(c, reply.add_codes());
  return reply;
}

v1::MotionsReply motions_reply_from_json(const json& body) {
  v1::MotionsReply reply;
  read_answered_by(body, reply.mutable_answered_by());
  for (const auto& m : body.value("motions", json::array())) read_motion(m, reply.add_motions());
  for (const auto& c : body.value("codes", json::array())) read_code(c, reply.add_codes());
  return reply;
}

v1::ModelInfo model_from_json(const json& body) {
  v1::ModelInfo model;
  model.set_name(body.value("name", ""));
  model.set_version(body.value("version", ""));
  model.set_active(body.value("active", false));
  model.set_loaded(body.value("loaded", false));
  model.set_variant(body.value("variant", ""));
  model.set_hidden(body.value("hidden", 0));
  model.set_latent(body.value("latent", 0));
  model.set_frames(body.value("frames", 0));
  model.set_columns(body.value("columns", 0));
  model.set_frame_rate(body.value("frame_rate", 0.0));
  model.set_layout(body.value("layout", ""));
  for (const auto& d : body.value("decoders", json::array())) model.add_decoders(d.get<std::string>());
  model.set_load_seconds(body.value("load_seconds", 0.0));
  model.set_provenance_json(embedded_text(body, "provenance"));
  model.set_evaluation_json(embedded_text(body, "evaluation"));
  model.set_model_card(body.value("model_card", ""));
  model.set_skeleton_json(embedded_text(body, "skeleton"));
  return model;
}

v1::ListModelsReply models_from_json(const json& body) {
  v1::ListModelsReply reply;
  for (const auto& m : body.value("models", json::array())) *reply.add_models() = model_from_json(m);
  return reply;
}

v1::ClipFile clip_file_from_json(const json& body) {
  v1::ClipFile clip;
  clip.set_path(body.value("path", ""));
  clip.set_format(body.value("format", ""));
  clip.set_size_bytes(integer<int64_t>(body, "size_bytes"));
  clip.set_uploaded(body.value("uploaded", false));
  return clip;
}

v1::ListClipsReply clips_from_json(const json& body) {
  v1::ListClipsReply reply;
  for (const auto& c : body.value("clips", json::array())) *reply.add_clips() = clip_file_from_json(c);
  reply.set_truncated(body.value("truncated", false));
  return reply;
}

v1::ReadClipReply clip_window_from_json(const json& body) {
  v1::ReadClipReply reply;
  reply.set_path(body.value("path", ""));
  reply.set_format(body.value("format", ""));
  reply.set_start(integer<int64_t>(body, "start"));
  reply.set_file_frames(integer<int64_t>(body, "file_frames"));
  reply.set_file_frame_rate(body.value("file_frame_rate", 0.0));
  reply.set_last_start(integer<int64_t>(body, "last_start"));
  if (body.contains("motion")) read_motion(body["motion"], reply.mutable_motion());
  return reply;
}

v1::Job job_from_json(const json& body) {
  v1::Job job;
  job.set_id(body.value("id", ""));
  if (body.contains("spec")) {
    const auto& s = body["spec"];
    auto* spec = job.mutable_spec();
    spec->set_dataset(s.value("dataset", ""));
    spec->set_variant(s.value("variant", ""));
    spec->set_config_json(embedded_text(s, "config"));
    spec->set_iterations(integer<int64_t>(s, "iterations"));
    spec->set_seed(integer<uint64_t>(s, "seed"));
    spec->set_hidden(s.value("hidden", 0));
    spec->set_batch(s.value("batch", 0));
    spec->set_model_name(s.value("model_name", ""));
  }
  job.set_state(body.value("state", ""));
  if (body.contains("progress")) {
    const auto& p = body["progress"];
    auto* progress = job.mutable_progress();
    progress->set_iteration(integer<int64_t>(p, "iteration"));
    progress->set_total(integer<int64_t>(p, "total"));
    const json losses = p.value("losses", json::object());  // items() must not outlive it
    for (const auto& [name, value] : losses.items()) {
      if (value.is_number()) (*progress->mutable_losses())[name] = value.get<double>();
    }
    progress->set_iterations_per_second(p.value("iterations_per_second", 0.0));
    progress->set_eta_seconds(p.value("eta_seconds", 0.0));
  }
  job.set_error(body.value("error", ""));
  job.set_published_model(body.value("published_model", ""));
  job.set_created_at(body.value("created_at", 0.0));
  job.set_started_at(body.value("started_at", 0.0));
  job.set_finished_at(body.value("finished_at", 0.0));
  job.set_resumes(body.value("resumes", 0));
  job.set_resolved_config_json(embedded_text(body, "resolved_config"));
  return job;
}

v1::ListJobsReply jobs_from_json(const json& body) {
  v1::ListJobsReply reply;
  for (const auto& j : body.value("jobs", json::array())) *reply.add_jobs() = job_from_json(j);
  return reply;
}

}  // namespace mm::client
