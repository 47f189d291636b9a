#include "wire/rest_json.h"

#include <cmath>

namespace mm::wire {

namespace {

using Floats = google::protobuf::RepeatedField<float>;

// ---- writing

FloatJson floats_json(const Floats& values) {
  FloatJson out = FloatJson::array();
  auto& array = out.get_ref<FloatJson::array_t&>();
  array.reserve(static_cast<size_t>(values.size()));
  // proto3's JSON mapping spells the non-finite floats as strings, as the
  // reader takes them: a value missing from a take (NaN) stays missing, where
  // JSON's own writer would make it null.
  for (const float v : values) {
    if (std::isfinite(v)) {
      array.emplace_back(v);
    } else {
      array.emplace_back(std::isnan(v) ? "NaN" : v > 0 ? "Infinity" : "-Infinity");
    }
  }
  return out;
}

FloatJson code_json(const v1::Code& code) { return floats_json(code.values()); }

FloatJson motion_json(const v1::Motion& motion) {
  FloatJson out{{"frames", motion.frames()},
                {"columns", motion.columns()},
                {"frame_rate", motion.frame_rate()},
                {"layout", motion.layout()},
                {"values", floats_json(motion.values())}};
  // A reply's: a request leaves both out.
  if (!motion.root().empty()) out["root"] = motion.root();
  if (motion.contacts_size() > 0) out["contacts"] = std::vector<uint32_t>(motion.contacts().begin(), motion.contacts().end());
  return out;
}

FloatJson motions_json(const google::protobuf::RepeatedPtrField<v1::Motion>& motions) {
  FloatJson out = FloatJson::array();
  for (const auto& motion : motions) out.push_back(motion_json(motion));
  return out;
}

FloatJson codes_json(const google::protobuf::RepeatedPtrField<v1::Code>& codes) {
  FloatJson out = FloatJson::array();
  for (const auto& code : codes) out.push_back(code_json(code));
  return out;
}

FloatJson motion_or_code_json(const v1::MotionOrCode& input) {
  if (input.has_motion()) return FloatJson{{"motion", motion_json(input.motion())}};
  if (input.has_code()) return FloatJson{{"code", code_json(input.code())}};
  return FloatJson::object();  // neither: the server's core names the field
}

FloatJson answered_by_json(const v1::AnsweredBy& answered_by) {
  return FloatJson{{"model", answered_by.model()}, {"version", answered_by.version()}};
}

// A window as encode answers it; a DecodeTrackRequest's leaves start_frame out.
FloatJson windows_json(const google::protobuf::RepeatedPtrField<v1::TakeWindow>& windows, bool with_start_frame) {
  FloatJson out = FloatJson::array();
  for (const auto& window : windows) {
    FloatJson item{{"start_seconds", window.start_seconds()}, {"code", code_json(window.code())}};
    if (with_start_frame) item["start_frame"] = window.start_frame();
    out.push_back(std::move(item));
  }
  return out;
}

// JSON text embedded as the object itself: {} for "", null when it is not
// JSON (never expected of the server, but no reason to fail the reply).
Json embedded(const std::string& text) {
  if (text.empty()) return Json::object();
  Json value = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  return value.is_discarded() ? Json(nullptr) : value;
}

// ---- reading

void read_motion(const Json& value, const std::string& path, UnknownFields unknown, v1::Motion* motion) {
  ObjectReader reader(value, path, unknown);
  motion->set_frames(reader.int32("frames"));
  motion->set_columns(reader.int32("columns"));
  motion->set_frame_rate(reader.number("frame_rate"));
  motion->set_layout(reader.string("layout"));
  reader.floats("values", motion->mutable_values());
  // A reply's members, accepted in a request (a motion a server sent may be
  // sent back) and there ignored.
  motion->set_root(reader.string("root"));
  if (const Json* v = reader.find("contacts")) {
    const std::string contacts = reader.path("contacts");
    if (!v->is_array()) throw type_error(contacts, "an array of integers", *v);
    for (size_t i = 0; i < v->size(); ++i) {
      if (!(*v)[i].is_number_unsigned() || (*v)[i].get<uint64_t>() > 0xffffffffu) {
        throw type_error(index_path(contacts, i), "an integer from 0 to 4294967295", (*v)[i]);
      }
      motion->add_contacts((*v)[i].get<uint32_t>());
    }
  }
  reader.finish();
}

void read_motions(ObjectReader& reader, const std::string& key, google::protobuf::RepeatedPtrField<v1::Motion>* out) {
  const Json* v = reader.find(key);
  if (v == nullptr) return;
  const std::string path = reader.path(key);
  if (!v->is_array()) throw type_error(path, "an array of motions", *v);
  out->Reserve(static_cast<int>(v->size()));
  for (size_t i = 0; i < v->size(); ++i) read_motion((*v)[i], index_path(path, i), reader.unknown(), out->Add());
}

void read_codes(ObjectReader& reader, const std::string& key, google::protobuf::RepeatedPtrField<v1::Code>* out) {
  const Json* v = reader.find(key);
  if (v == nullptr) return;
  const std::string path = reader.path(key);
  if (!v->is_array()) throw type_error(path, "an array of codes (arrays of numbers)", *v);
  out->Reserve(static_cast<int>(v->size()));
  for (size_t i = 0; i < v->size(); ++i) read_floats((*v)[i], index_path(path, i), out->Add()->mutable_values());
}

// {"motion": {...}} or {"code": [...]}; {} (neither) leaves the field unset,
// as the writer found it. `out()` gives the field to fill.
template <typename Field>
void read_motion_or_code(ObjectReader& parent, const std::string& key, Field&& out) {
  const Json* v = parent.find(key);
  if (v == nullptr) return;
  ObjectReader reader(*v, parent.path(key), parent.unknown());
  v1::Motion motion;
  v1::Code code;
  const Json* motion_value = reader.find("motion");
  if (motion_value != nullptr) read_motion(*motion_value, reader.path("motion"), reader.unknown(), &motion);
  const Json* code_value = reader.find("code");
  if (code_value != nullptr) read_floats(*code_value, reader.path("code"), code.mutable_values());
  reader.finish();
  if (motion_value != nullptr && code_value != nullptr) {
    // The oneof holds one: refused here, in the core's words.
    throw InputError(parent.path(key), "expected exactly one of motion or code, found both");
  }
  if (motion_value != nullptr) out()->mutable_motion()->Swap(&motion);
  if (code_value != nullptr) out()->mutable_code()->Swap(&code);
}

void read_answered_by(ObjectReader& parent, v1::AnsweredBy* out) {
  const Json* v = parent.find("answered_by");
  if (v == nullptr) return;
  ObjectReader reader(*v, parent.path("answered_by"), parent.unknown());
  out->set_model(reader.string("model"));
  out->set_version(reader.string("version"));
  reader.finish();
}

void read_windows(ObjectReader& parent, google::protobuf::RepeatedPtrField<v1::TakeWindow>* out) {
  const Json* v = parent.find("windows");
  if (v == nullptr) return;
  const std::string path = parent.path("windows");
  if (!v->is_array()) throw type_error(path, "an array of windows ({\"start_seconds\", \"code\"})", *v);
  out->Reserve(static_cast<int>(v->size()));
  for (size_t i = 0; i < v->size(); ++i) {
    ObjectReader reader((*v)[i], index_path(path, i), parent.unknown());
    v1::TakeWindow* window = out->Add();
    window->set_start_seconds(reader.number("start_seconds"));
    window->set_start_frame(reader.int64("start_frame"));
    reader.floats("code", window->mutable_code()->mutable_values());
    reader.finish();
  }
}

void read_spec(ObjectReader& reader, v1::JobSpec* spec) {
  spec->set_dataset(reader.string("dataset"));
  spec->set_variant(reader.string("variant"));
  spec->set_config_json(reader.object_text("config", "the training configuration"));
  spec->set_iterations(reader.int64("iterations"));
  spec->set_seed(reader.uint64("seed"));
  spec->set_hidden(reader.int32("hidden"));
  spec->set_batch(reader.int32("batch"));
  spec->set_model_name(reader.string("model_name"));
}

// Each member of the array `key` read by `read_one(item, path, out->Add())`.
template <typename Message, typename ReadOne>
void read_list(ObjectReader& reader, const std::string& key, google::protobuf::RepeatedPtrField<Message>* out,
               ReadOne&& read_one) {
  const Json* v = reader.find(key);
  if (v == nullptr) return;
  const std::string path = reader.path(key);
  if (!v->is_array()) throw type_error(path, "an array", *v);
  out->Reserve(static_cast<int>(v->size()));
  for (size_t i = 0; i < v->size(); ++i) read_one((*v)[i], index_path(path, i), out->Add());
}

// An array of strings, when the member is there.
void read_strings(ObjectReader& reader, const std::string& key, google::protobuf::RepeatedPtrField<std::string>* out) {
  const Json* v = reader.find(key);
  if (v == nullptr) return;
  const std::string path = reader.path(key);
  if (!v->is_array()) throw type_error(path, "an array of strings", *v);
  for (size_t i = 0; i < v->size(); ++i) {
    if (!(*v)[i].is_string()) throw type_error(index_path(path, i), "a string", (*v)[i]);
    out->Add((*v)[i].get<std::string>());
  }
}

void read_model(const Json& body, const std::string& path, UnknownFields unknown, v1::ModelInfo* model) {
  ObjectReader reader(body, path, unknown);
  model->set_name(reader.string("name"));
  model->set_version(reader.string("version"));
  model->set_active(reader.boolean("active"));
  model->set_loaded(reader.boolean("loaded"));
  model->set_variant(reader.string("variant"));
  model->set_hidden(reader.int32("hidden"));
  model->set_latent(reader.int32("latent"));
  model->set_frames(reader.int32("frames"));
  model->set_columns(reader.int32("columns"));
  model->set_frame_rate(reader.number("frame_rate"));
  model->set_layout(reader.string("layout"));
  read_strings(reader, "decoders", model->mutable_decoders());
  model->set_load_seconds(reader.number("load_seconds"));
  model->set_precision(reader.string("precision"));
  model->set_trajectory(reader.boolean("trajectory"));
  read_strings(reader, "feet", model->mutable_feet());
  model->set_provenance_json(reader.object_text("provenance", "the model's provenance"));
  model->set_evaluation_json(reader.object_text("evaluation", "the model's evaluation"));
  model->set_model_card(reader.string("model_card"));
  model->set_skeleton_json(reader.object_text("skeleton", "the model's skeleton"));
  reader.finish();
}

void read_clip(const Json& body, const std::string& path, UnknownFields unknown, v1::ClipFile* clip) {
  ObjectReader reader(body, path, unknown);
  clip->set_path(reader.string("path"));
  clip->set_format(reader.string("format"));
  clip->set_size_bytes(reader.int64("size_bytes"));
  clip->set_uploaded(reader.boolean("uploaded"));
  reader.finish();
}

void read_job(const Json& body, const std::string& path, UnknownFields unknown, v1::Job* job) {
  ObjectReader reader(body, path, unknown);
  job->set_id(reader.string("id"));
  if (const Json* v = reader.find("spec")) {
    ObjectReader spec(*v, reader.path("spec"), unknown);
    read_spec(spec, job->mutable_spec());
    spec.finish();
  }
  job->set_state(reader.string("state"));
  if (const Json* v = reader.find("progress")) {
    ObjectReader progress(*v, reader.path("progress"), unknown);
    v1::JobProgress* out = job->mutable_progress();
    out->set_iteration(progress.int64("iteration"));
    out->set_total(progress.int64("total"));
    if (const Json* losses = progress.find("losses")) {
      ObjectReader terms(*losses, progress.path("losses"), UnknownFields::kIgnore);
      for (auto it = losses->begin(); it != losses->end(); ++it) {
        // A term that is NaN was written as null (JSON has no NaN): left out.
        if (!it->is_null()) (*out->mutable_losses())[it.key()] = terms.number(it.key());
      }
    }
    out->set_iterations_per_second(progress.number("iterations_per_second"));
    out->set_eta_seconds(progress.number("eta_seconds"));
    progress.finish();
  }
  job->set_error(reader.string("error"));
  job->set_published_model(reader.string("published_model"));
  job->set_created_at(reader.number("created_at"));
  job->set_started_at(reader.number("started_at"));
  job->set_finished_at(reader.number("finished_at"));
  job->set_resumes(reader.int32("resumes"));
  job->set_resolved_config_json(reader.object_text("resolved_config", "the job's resolved training configuration"));
  reader.finish();
}

FloatJson summary_fields_json(const v1::TakeSummary& summary) {
  return FloatJson{{"frames", summary.frames()},
                   {"input_frames", summary.input_frames()},
                   {"mean_error_mm", summary.mean_error_mm()},
                   {"max_error_mm", summary.max_error_mm()},
                   {"window_seconds", summary.window_seconds()},
                   {"hop_seconds", summary.hop_seconds()},
                   {"gap_windows_fitted", summary.gap_windows_fitted()},
                   {"gaps_fitted", summary.gaps_fitted()},
                   {"gaps_over_fit_limit", summary.gaps_over_fit_limit()}};
}

}  // namespace

// ---- Requests

FloatJson to_json(const v1::EncodeRequest& request) {
  return FloatJson{{"model", request.model()}, {"motions", motions_json(request.motions())}};
}

Json to_json(const v1::SampleRequest& request) {
  Json out{{"model", request.model()}, {"seed", request.seed()}, {"decoder", request.decoder()}};
  if (request.count() != 0) out["count"] = request.count();
  if (request.plant_feet()) out["plant_feet"] = true;
  return out;
}

FloatJson to_json(const v1::DecodeRequest& request) {
  FloatJson out{{"model", request.model()}, {"codes", codes_json(request.codes())}, {"decoder", request.decoder()}};
  if (request.plant_feet()) out["plant_feet"] = true;
  return out;
}

FloatJson to_json(const v1::InterpolateRequest& request) {
  FloatJson out{{"model", request.model()},
                {"from", motion_or_code_json(request.from())},
                {"to", motion_or_code_json(request.to())},
                {"decoder", request.decoder()}};
  if (request.steps() != 0) out["steps"] = request.steps();
  if (!request.method().empty()) out["method"] = request.method();
  if (request.plant_feet()) out["plant_feet"] = true;
  return out;
}

FloatJson to_json(const v1::AnalogyRequest& request) {
  FloatJson out{{"model", request.model()},
                {"a", motion_or_code_json(request.a())},
                {"b", motion_or_code_json(request.b())},
                {"c", motion_or_code_json(request.c())},
                {"decoder", request.decoder()}};
  if (request.plant_feet()) out["plant_feet"] = true;
  return out;
}

FloatJson to_json(const v1::DenoiseRequest& request) {
  FloatJson out{{"model", request.model()},
                {"motions", motions_json(request.motions())},
                {"decoder", request.decoder()},
                {"zeros_are_missing", request.zeros_are_missing()},
                {"means_are_missing", request.means_are_missing()},
                {"keep_observed", request.keep_observed()}};
  if (request.iterations() != 0) out["iterations"] = request.iterations();
  return out;
}

FloatJson to_json(const v1::JoinClipsRequest& request) {
  FloatJson out{{"model", request.model()},
                {"a", motion_json(request.a())},
                {"b", motion_json(request.b())},
                {"decoder", request.decoder()}};
  if (request.transition_seconds() != 0) out["transition_seconds"] = request.transition_seconds();
  if (!request.method().empty()) out["method"] = request.method();
  return out;
}

Json to_json(const v1::JobSpec& spec) {
  Json out{{"dataset", spec.dataset()}, {"iterations", spec.iterations()}, {"seed", spec.seed()},
           {"hidden", spec.hidden()},   {"batch", spec.batch()},           {"model_name", spec.model_name()}};
  if (!spec.variant().empty()) out["variant"] = spec.variant();
  if (!spec.config_json().empty()) out["config"] = embedded(spec.config_json());
  return out;
}

FloatJson to_json(const v1::DecodeTrackRequest& request) {
  FloatJson out{{"model", request.model()},
                {"windows", windows_json(request.windows(), /*with_start_frame=*/false)},
                {"frame_rate", request.frame_rate()},
                {"frames", request.frames()}};
  if (!request.decoder().empty()) out["decoder"] = request.decoder();
  if (!request.blend().empty()) out["blend"] = request.blend();
  return out;
}

void from_json(const Json& body, v1::EncodeRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_motions(reader, "motions", out.mutable_motions());
  reader.finish();
}

void from_json(const Json& body, v1::SampleRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  out.set_count(reader.int32("count"));
  out.set_seed(reader.uint64("seed"));
  out.set_decoder(reader.string("decoder"));
  out.set_plant_feet(reader.boolean("plant_feet"));
  reader.finish();
}

void from_json(const Json& body, v1::DecodeRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_codes(reader, "codes", out.mutable_codes());
  out.set_decoder(reader.string("decoder"));
  out.set_plant_feet(reader.boolean("plant_feet"));
  reader.finish();
}

void from_json(const Json& body, v1::InterpolateRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_motion_or_code(reader, "from", [&out] { return out.mutable_from(); });
  read_motion_or_code(reader, "to", [&out] { return out.mutable_to(); });
  out.set_steps(reader.int32("steps"));
  out.set_method(reader.string("method"));
  out.set_decoder(reader.string("decoder"));
  out.set_plant_feet(reader.boolean("plant_feet"));
  reader.finish();
}

void from_json(const Json& body, v1::AnalogyRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_motion_or_code(reader, "a", [&out] { return out.mutable_a(); });
  read_motion_or_code(reader, "b", [&out] { return out.mutable_b(); });
  read_motion_or_code(reader, "c", [&out] { return out.mutable_c(); });
  out.set_decoder(reader.string("decoder"));
  out.set_plant_feet(reader.boolean("plant_feet"));
  reader.finish();
}

void from_json(const Json& body, v1::DenoiseRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_motions(reader, "motions", out.mutable_motions());
  out.set_decoder(reader.string("decoder"));
  out.set_zeros_are_missing(reader.boolean("zeros_are_missing"));
  out.set_means_are_missing(reader.boolean("means_are_missing"));
  out.set_iterations(reader.int32("iterations"));
  out.set_keep_observed(reader.boolean("keep_observed"));
  reader.finish();
}

void from_json(const Json& body, v1::JoinClipsRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  // A clip left out stays an empty motion, which the core refuses naming it.
  if (const Json* a = reader.find("a")) read_motion(*a, reader.path("a"), reader.unknown(), out.mutable_a());
  if (const Json* b = reader.find("b")) read_motion(*b, reader.path("b"), reader.unknown(), out.mutable_b());
  out.set_transition_seconds(reader.number("transition_seconds"));
  out.set_method(reader.string("method"));
  out.set_decoder(reader.string("decoder"));
  reader.finish();
}

void from_json(const Json& body, v1::JobSpec& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_spec(reader, &out);
  reader.finish();
}

void from_json(const Json& body, v1::DecodeTrackRequest& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_model(reader.string("model"));
  read_windows(reader, out.mutable_windows());
  out.set_frame_rate(reader.number("frame_rate"));
  out.set_frames(reader.int64("frames"));
  out.set_decoder(reader.string("decoder"));
  out.set_blend(reader.string("blend"));
  reader.finish();
}

void empty_from_json(const Json& body, UnknownFields unknown) { ObjectReader(body, "", unknown).finish(); }

// ---- Replies

FloatJson to_json(const v1::EncodeReply& reply) {
  return FloatJson{{"answered_by", answered_by_json(reply.answered_by())}, {"codes", codes_json(reply.codes())}};
}

FloatJson to_json(const v1::MotionsReply& reply) {
  return FloatJson{{"answered_by", answered_by_json(reply.answered_by())},
                   {"motions", motions_json(reply.motions())},
                   {"codes", codes_json(reply.codes())}};
}

FloatJson to_json(const v1::JoinClipsReply& reply) {
  return FloatJson{{"answered_by", answered_by_json(reply.answered_by())},
                   {"motion", motion_json(reply.motion())},
                   {"transition_first_frame", reply.transition_first_frame()},
                   {"transition_last_frame", reply.transition_last_frame()}};
}

Json to_json(const v1::ModelInfo& model) {
  return Json{{"name", model.name()},
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
              {"precision", model.precision()},
              {"trajectory", model.trajectory()},
              {"feet", std::vector<std::string>(model.feet().begin(), model.feet().end())},
              {"provenance", embedded(model.provenance_json())},
              {"evaluation", embedded(model.evaluation_json())},
              {"model_card", model.model_card()},
              {"skeleton", embedded(model.skeleton_json())}};
}

Json to_json(const v1::ListModelsReply& reply) {
  Json models = Json::array();
  for (const auto& model : reply.models()) models.push_back(to_json(model));
  return Json{{"models", std::move(models)}};
}

Json to_json(const v1::ClipFile& clip) {
  return Json{{"path", clip.path()},
              {"format", clip.format()},
              {"size_bytes", clip.size_bytes()},
              {"uploaded", clip.uploaded()}};
}

Json to_json(const v1::ListClipsReply& reply) {
  Json clips = Json::array();
  for (const auto& clip : reply.clips()) clips.push_back(to_json(clip));
  return Json{{"clips", std::move(clips)}, {"truncated", reply.truncated()}};
}

FloatJson to_json(const v1::ReadClipReply& reply) {
  return FloatJson{{"path", reply.path()},
                   {"format", reply.format()},
                   {"start", reply.start()},
                   {"file_frames", reply.file_frames()},
                   {"file_frame_rate", reply.file_frame_rate()},
                   {"last_start", reply.last_start()},
                   {"motion", motion_json(reply.motion())}};
}

Json to_json(const v1::Job& job) {
  const v1::JobProgress& p = job.progress();
  Json spec = to_json(job.spec());
  // A record's variant is written even when empty (a request leaves it out).
  if (!spec.contains("variant")) spec["variant"] = job.spec().variant();
  // std::map: the terms in name order, whatever the proto map's order.
  const std::map<std::string, double> losses(p.losses().begin(), p.losses().end());
  return Json{{"id", job.id()},
              {"spec", std::move(spec)},
              {"state", job.state()},
              {"progress",
               {{"iteration", p.iteration()},
                {"total", p.total()},
                {"losses", losses},
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

Json to_json(const v1::ListJobsReply& reply) {
  Json jobs = Json::array();
  for (const auto& job : reply.jobs()) jobs.push_back(to_json(job));
  return Json{{"jobs", std::move(jobs)}};
}

FloatJson to_json(const v1::CodeTrack& track) {
  return FloatJson{{"answered_by", answered_by_json(track.answered_by())},
                   {"frames", track.frames()},
                   {"frame_rate", track.frame_rate()},
                   {"window_seconds", track.window_seconds()},
                   {"hop_seconds", track.hop_seconds()},
                   {"windows", windows_json(track.windows(), /*with_start_frame=*/true)}};
}

FloatJson to_json(const v1::TakeSummary& summary) {
  return FloatJson{{"summary", summary_fields_json(summary)},
                   {"windows", windows_json(summary.windows(), /*with_start_frame=*/true)}};
}

FloatJson to_json(const TakeReply& reply) {
  FloatJson out = to_json(reply.summary);
  out["answered_by"] = answered_by_json(reply.header.answered_by());
  out["frame_rate"] = reply.header.frame_rate();
  out["columns"] = reply.header.columns();
  out["layout"] = reply.header.layout();
  out["frames"] = static_cast<int64_t>(reply.frames.frames());
  out["values"] = floats_json(reply.frames.values());
  out["error_mm"] = floats_json(reply.frames.error_mm());
  return out;
}

void from_json(const Json& body, v1::EncodeReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_answered_by(reader, out.mutable_answered_by());
  read_codes(reader, "codes", out.mutable_codes());
  reader.finish();
}

void from_json(const Json& body, v1::MotionsReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_answered_by(reader, out.mutable_answered_by());
  read_motions(reader, "motions", out.mutable_motions());
  read_codes(reader, "codes", out.mutable_codes());
  reader.finish();
}

void from_json(const Json& body, v1::JoinClipsReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_answered_by(reader, out.mutable_answered_by());
  if (const Json* motion = reader.find("motion")) {
    read_motion(*motion, reader.path("motion"), reader.unknown(), out.mutable_motion());
  }
  out.set_transition_first_frame(reader.int32("transition_first_frame"));
  out.set_transition_last_frame(reader.int32("transition_last_frame"));
  reader.finish();
}

void from_json(const Json& body, v1::ModelInfo& out, UnknownFields unknown) {
  out.Clear();
  read_model(body, "", unknown, &out);
}

void from_json(const Json& body, v1::ListModelsReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_list(reader, "models", out.mutable_models(),
            [unknown](const Json& item, const std::string& path, v1::ModelInfo* model) {
              read_model(item, path, unknown, model);
            });
  reader.finish();
}

void from_json(const Json& body, v1::ClipFile& out, UnknownFields unknown) {
  out.Clear();
  read_clip(body, "", unknown, &out);
}

void from_json(const Json& body, v1::ListClipsReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_list(reader, "clips", out.mutable_clips(),
            [unknown](const Json& item, const std::string& path, v1::ClipFile* clip) {
              read_clip(item, path, unknown, clip);
            });
  out.set_truncated(reader.boolean("truncated"));
  reader.finish();
}

void from_json(const Json& body, v1::ReadClipReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  out.set_path(reader.string("path"));
  out.set_format(reader.string("format"));
  out.set_start(reader.int64("start"));
  out.set_file_frames(reader.int64("file_frames"));
  out.set_file_frame_rate(reader.number("file_frame_rate"));
  out.set_last_start(reader.int64("last_start"));
  if (const Json* motion = reader.find("motion")) {
    read_motion(*motion, reader.path("motion"), unknown, out.mutable_motion());
  }
  reader.finish();
}

void from_json(const Json& body, v1::Job& out, UnknownFields unknown) {
  out.Clear();
  read_job(body, "", unknown, &out);
}

void from_json(const Json& body, v1::ListJobsReply& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_list(reader, "jobs", out.mutable_jobs(), [unknown](const Json& item, const std::string& path, v1::Job* job) {
    read_job(item, path, unknown, job);
  });
  reader.finish();
}

void from_json(const Json& body, v1::CodeTrack& out, UnknownFields unknown) {
  out.Clear();
  ObjectReader reader(body, "", unknown);
  read_answered_by(reader, out.mutable_answered_by());
  out.set_frames(reader.int64("frames"));
  out.set_frame_rate(reader.number("frame_rate"));
  out.set_window_seconds(reader.number("window_seconds"));
  out.set_hop_seconds(reader.number("hop_seconds"));
  read_windows(reader, out.mutable_windows());
  reader.finish();
}

void from_json(const Json& body, TakeReply& out, UnknownFields unknown) {
  out.header.Clear();
  out.frames.Clear();
  out.summary.Clear();
  ObjectReader reader(body, "", unknown);
  read_answered_by(reader, out.header.mutable_answered_by());
  out.header.set_frame_rate(reader.number("frame_rate"));
  out.header.set_columns(reader.int32("columns"));
  out.header.set_layout(reader.string("layout"));
  out.frames.set_frames(reader.int32("frames"));
  reader.floats("values", out.frames.mutable_values());
  reader.floats("error_mm", out.frames.mutable_error_mm());
  if (const Json* v = reader.find("summary")) {
    ObjectReader summary(*v, reader.path("summary"), unknown);
    out.summary.set_frames(summary.int64("frames"));
    out.summary.set_input_frames(summary.int64("input_frames"));
    out.summary.set_mean_error_mm(summary.number("mean_error_mm"));
    out.summary.set_max_error_mm(summary.number("max_error_mm"));
    out.summary.set_window_seconds(summary.number("window_seconds"));
    out.summary.set_hop_seconds(summary.number("hop_seconds"));
    out.summary.set_gap_windows_fitted(summary.int32("gap_windows_fitted"));
    out.summary.set_gaps_fitted(summary.int32("gaps_fitted"));
    out.summary.set_gaps_over_fit_limit(summary.int32("gaps_over_fit_limit"));
    summary.finish();
  }
  read_windows(reader, out.summary.mutable_windows());
  reader.finish();
}

std::string body_text(const Json& document) { return document.dump(-1, ' ', false, Json::error_handler_t::replace); }

std::string body_text(const FloatJson& document) {
  return document.dump(-1, ' ', false, FloatJson::error_handler_t::replace);
}

}  // namespace mm::wire
