#include "rest/json_translation.h"


#include <cfloat>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>

#include <nlohmann/json.hpp>

#include "format/json_text.h"

namespace mm::service::rest {

namespace {

using json = nlohmann::json;
// Motions and codes are float32 in the core: written through a float-typed
// document, nlohmann prints each value's shortest float form ("0.106")
// instead of the double's 17 digits of the same float, a third of the size.
using FloatJson = nlohmann::basic_json<std::map, std::vector, std::string, bool, std::int64_t, std::uint64_t, float>;

ApiError type_error(const std::string& path, const std::string& expected, const json& value) {
  return ApiError(ErrorCode::kInvalidArgument, path,
                  "expected " + expected + ", got " + std::string(value.type_name()));
}

std::string member_path(const std::string& parent, const std::string& key) {
  return parent.empty() ? key : parent + "." + key;
}

std::string index_path(const std::string& parent, size_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

json parse_body(const std::string& body) {
  // Refused before parsing: the translation prints parts of a body (a job's
  // configuration), which recurses once per level of nesting.
  if (json_nesting_depth(body) > kMaxJsonDepth) {
    throw ApiError(ErrorCode::kInvalidArgument, "",
                   "the JSON body nests arrays and objects deeper than " + std::to_string(kMaxJsonDepth) +
                       " levels, expected a request of a few");
  }
  try {
    return json::parse(body);
  } catch (const json::exception& e) {
    // A syntax error (parse_error, with its byte) or a number beyond a
    // double's range (out_of_range). e.what() reads "[json.exception.
    // parse_error.101] parse error at line 1, column 7: ..."; the bracketed
    // id means nothing to a client.
    std::string what = e.what();
    const size_t close = what.find("] ");
    if (close != std::string::npos && what.rfind("[json.exception", 0) == 0) what = what.substr(close + 2);
    const auto* syntax = dynamic_cast<const json::parse_error*>(&e);
    throw ApiError(ErrorCode::kInvalidArgument, "",
                   "malformed JSON" + (syntax ? " (byte " + std::to_string(syntax->byte) + ")" : std::string()) + ": " +
                       what);
  }
}

// Reads an integer-valued JSON number (150, 150.0, 1.5e2) or, where proto3
// allows it, a decimal string; range-checked against [lo, hi].
template <typename T>
T read_integer(const json& value, const std::string& path, bool strings_allowed) {
  const char* expected = std::is_signed<T>::value ? (sizeof(T) == 8 ? "a 64-bit integer" : "a 32-bit integer")
                                                   : "a non-negative 64-bit integer";
  if (value.is_number_unsigned()) {
    const uint64_t v = value.get<uint64_t>();
    if (v > static_cast<uint64_t>(std::numeric_limits<T>::max())) throw type_error(path, expected, value);
    return static_cast<T>(v);
  }
  if (value.is_number_integer()) {
    const int64_t v = value.get<int64_t>();
    if (v < static_cast<int64_t>(std::numeric_limits<T>::min()) ||
        (v > 0 && static_cast<uint64_t>(v) > static_cast<uint64_t>(std::numeric_limits<T>::max())))
      throw ApiError(ErrorCode::kInvalidArgument, path,
                     "expected " + std::string(expected) + ", got " + std::to_string(v));
    return static_cast<T>(v);
  }
  if (value.is_number_float()) {
    const double v = value.get<double>();
    // Below 2^digits, exclusive: a 64-bit max converted to double rounds up
    // to that power of two, which is itself out of range.
    if (!(std::floor(v) == v) || v < static_cast<double>(std::numeric_limits<T>::min()) ||
        v >= std::ldexp(1.0, std::numeric_limits<T>::digits))
      throw ApiError(ErrorCode::kInvalidArgument, path, "expected " + std::string(expected) + ", got " + value.dump());
    return static_cast<T>(v);
  }
  if (value.is_string() && strings_allowed) {
    const std::string& text = value.get_ref<const std::string&>();
    // Digits only, with a minus sign where T is signed: stoll and stoull
    // would also take leading blanks and a plus sign, and stoull a minus
    // sign, negating the number into a huge one.
    const size_t first_digit = std::is_signed<T>::value && !text.empty() && text[0] == '-' ? 1 : 0;
    const bool digits = text.size() > first_digit &&
                        text.find_first_not_of("0123456789", first_digit) == std::string::npos;
    try {
      if (digits && std::is_signed<T>::value) {
        const long long v = std::stoll(text);
        if (v >= static_cast<long long>(std::numeric_limits<T>::min()) &&
            v <= static_cast<long long>(std::numeric_limits<T>::max()))
          return static_cast<T>(v);
      } else if (digits) {
        return static_cast<T>(std::stoull(text));
      }
    } catch (const std::out_of_range&) {
    }
    throw ApiError(ErrorCode::kInvalidArgument, path,
                   "expected " + std::string(expected) + " (a number or its decimal string), got \"" + text + "\"");
  }
  throw type_error(path, expected, value);
}

double read_double(const json& value, const std::string& path) {
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) {
    // proto3's JSON mapping spells the non-finite floats as strings; they
    // pass through so that the core, not the frontend, refuses them.
    const std::string& text = value.get_ref<const std::string&>();
    if (text == "NaN") return std::numeric_limits<double>::quiet_NaN();
    if (text == "Infinity") return std::numeric_limits<double>::infinity();
    if (text == "-Infinity") return -std::numeric_limits<double>::infinity();
  }
  throw type_error(path, "a number", value);
}

float read_float(const json& value, const std::string& path) {
  const double v = read_double(value, path);
  // Out of float's range is infinite (converting it is undefined behaviour);
  // the core refuses it as it refuses any non-finite value.
  if (v > FLT_MAX) return std::numeric_limits<float>::infinity();
  if (v < -FLT_MAX) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(v);
}

std::vector<float> read_floats(const json& value, const std::string& path) {
  if (!value.is_array()) throw type_error(path, "an array of numbers", value);
  std::vector<float> out;
  out.reserve(value.size());
  for (size_t i = 0; i < value.size(); ++i) {
    const json& element = value[i];
    // The common case first: this loop runs for every value of every frame.
    if (element.is_number()) {
      const double v = element.get<double>();
      out.push_back(v > FLT_MAX    ? std::numeric_limits<float>::infinity()
                    : v < -FLT_MAX ? -std::numeric_limits<float>::infinity()
                                   : static_cast<float>(v));
    } else {
      out.push_back(read_float(element, index_path(path, i)));
    }
  }
  return out;
}

// One JSON object of a request: hands out its members by name, then refuses
// any member nobody asked for, so that a misspelt field ("zeros_missing")
// is an error rather than a silently ignored option.
class ObjectReader {
 public:
  ObjectReader(const json& value, std::string path) : value_(value), path_(std::move(path)) {
    if (!value.is_object()) throw type_error(path_.empty() ? "" : path_, "an object", value);
  }

  // The member, or nullptr when absent or null (proto3: the default).
  const json* find(const std::string& key) {
    known_.insert(key);
    const auto it = value_.find(key);
    if (it == value_.end() || it->is_null()) return nullptr;
    return &*it;
  }
  std::string path(const std::string& key) const { return member_path(path_, key); }

  void read(const std::string& key, std::string& out) {
    if (const json* v = find(key)) {
      if (!v->is_string()) throw type_error(path(key), "a string", *v);
      out = v->get<std::string>();
    }
  }
  void read(const std::string& key, bool& out) {
    if (const json* v = find(key)) {
      if (!v->is_boolean()) throw type_error(path(key), "a boolean (true or false)", *v);
      out = v->get<bool>();
    }
  }
  void read(const std::string& key, int& out) {
    if (const json* v = find(key)) out = read_integer<int>(*v, path(key), false);
  }
  void read(const std::string& key, int64_t& out) {
    if (const json* v = find(key)) out = read_integer<int64_t>(*v, path(key), true);
  }
  void read(const std::string& key, uint64_t& out) {
    if (const json* v = find(key)) out = read_integer<uint64_t>(*v, path(key), true);
  }
  void read(const std::string& key, double& out) {
    if (const json* v = find(key)) out = read_double(*v, path(key));
  }

  // Call after the last read: INVALID_ARGUMENT for a member not read.
  void finish() const {
    for (auto it = value_.begin(); it != value_.end(); ++it) {
      if (known_.count(it.key()) == 0) {
        std::string names;
        for (const auto& name : known_) names += (names.empty() ? "" : ", ") + name;
        throw ApiError(ErrorCode::kInvalidArgument, path(it.key()),
                       names.empty() ? "unknown field; this call takes no fields"
                                     : "unknown field; expected one of: " + names);
      }
    }
  }

 private:
  const json& value_;
  std::string path_;
  std::set<std::string> known_;
};

Motion read_motion(const json& value, const std::string& path) {
  ObjectReader reader(value, path);
  Motion motion;
  reader.read("frames", motion.frames);
  reader.read("columns", motion.columns);
  reader.read("frame_rate", motion.frame_rate);
  reader.read("layout", motion.layout);
  if (const json* v = reader.find("values")) motion.values = read_floats(*v, reader.path("values"));
  reader.finish();
  return motion;
}

std::vector<Motion> read_motions(ObjectReader& reader, const std::string& key) {
  std::vector<Motion> motions;
  if (const json* v = reader.find(key)) {
    const std::string path = reader.path(key);
    if (!v->is_array()) throw type_error(path, "an array of motions", *v);
    for (size_t i = 0; i < v->size(); ++i) motions.push_back(read_motion((*v)[i], index_path(path, i)));
  }
  return motions;
}

std::vector<Code> read_codes(ObjectReader& reader, const std::string& key) {
  std::vector<Code> codes;
  if (const json* v = reader.find(key)) {
    const std::string path = reader.path(key);
    if (!v->is_array()) throw type_error(path, "an array of codes (arrays of numbers)", *v);
    for (size_t i = 0; i < v->size(); ++i) codes.push_back(read_floats((*v)[i], index_path(path, i)));
  }
  return codes;
}

MotionOrCode read_motion_or_code(ObjectReader& parent, const std::string& key) {
  MotionOrCode out;
  if (const json* v = parent.find(key)) {
    ObjectReader reader(*v, parent.path(key));
    if (const json* motion = reader.find("motion")) out.motion = read_motion(*motion, reader.path("motion"));
    if (const json* code = reader.find("code")) out.code = read_floats(*code, reader.path("code"));
    reader.finish();
  }
  return out;
}

FloatJson code_json(const Code& code) { return FloatJson(code); }

FloatJson motion_json(const Motion& motion) {
  return FloatJson{{"frames", motion.frames},
                   {"columns", motion.columns},
                   {"frame_rate", motion.frame_rate},
                   {"layout", motion.layout},
                   {"values", motion.values}};
}

FloatJson answered_by_json(const AnsweredBy& answered_by) {
  return FloatJson{{"model", answered_by.model}, {"version", answered_by.version}};
}

// Text the core holds as JSON, embedded as the object itself; null when it
// is not JSON (never expected of the core, but no reason to fail the reply).
json embedded_json(const std::string& text) {
  if (text.empty()) return json::object();
  json value = json::parse(text, nullptr, /*allow_exceptions=*/false);
  return value.is_discarded() ? json(nullptr) : value;
}

json model_json(const ModelInfo& model) {
  return json{{"name", model.name},
              {"version", model.version},
              {"active", model.active},
              {"loaded", model.loaded},
              {"variant", model.variant},
              {"hidden", model.hidden},
              {"latent", model.latent},
              {"frames", model.frames},
              {"columns", model.columns},
              {"frame_rate", model.frame_rate},
              {"layout", model.layout},
              {"decoders", model.decoders},
              {"load_seconds", model.load_seconds},
              {"provenance", embedded_json(model.provenance_json)},
              {"evaluation", embedded_json(model.evaluation_json)},
              {"model_card", model.model_card},
              {"skeleton", embedded_json(model.skeleton_json)}};
}

json job_spec_json(const JobSpec& spec) {
  json out{{"dataset", spec.dataset},   {"variant", spec.variant}, {"iterations", spec.iterations},
           {"seed", spec.seed},         {"hidden", spec.hidden},   {"batch", spec.batch},
           {"model_name", spec.model_name}};
  if (!spec.config_json.empty()) out["config"] = embedded_json(spec.config_json);
  return out;
}

json job_json(const JobInfo& job) {
  const JobProgress& p = job.progress;
  return json{{"id", job.id},
              {"spec", job_spec_json(job.spec)},
              {"state", job_state_name(job.state)},
              {"progress",
               {{"iteration", p.iteration},
                {"total", p.total},
                {"losses", p.losses},
                {"iterations_per_second", p.iterations_per_second},
                {"eta_seconds", p.eta_seconds}}},
              {"error", job.error},
              {"published_model", job.published_model},
              {"created_at", job.created_at},
              {"started_at", job.started_at},
              {"finished_at", job.finished_at},
              {"resumes", job.resumes},
              {"resolved_config", embedded_json(job.resolved_config_json)}};
}

std::string dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }
std::string dump(const FloatJson& value) { return value.dump(-1, ' ', false, FloatJson::error_handler_t::replace); }

}  // namespace

EncodeRequest encode_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  EncodeRequest request;
  reader.read("model", request.model);
  request.motions = read_motions(reader, "motions");
  reader.finish();
  return request;
}

DecodeRequest decode_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  DecodeRequest request;
  reader.read("model", request.model);
  request.codes = read_codes(reader, "codes");
  reader.read("decoder", request.decoder);
  reader.finish();
  return request;
}

SampleRequest sample_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  SampleRequest request;
  reader.read("model", request.model);
  reader.read("count", request.count);
  reader.read("seed", request.seed);
  reader.read("decoder", request.decoder);
  reader.finish();
  return request;
}

InterpolateRequest interpolate_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  InterpolateRequest request;
  reader.read("model", request.model);
  request.from = read_motion_or_code(reader, "from");
  request.to = read_motion_or_code(reader, "to");
  reader.read("steps", request.steps);
  reader.read("method", request.method);
  reader.read("decoder", request.decoder);
  reader.finish();
  return request;
}

AnalogyRequest analogy_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  AnalogyRequest request;
  reader.read("model", request.model);
  request.a = read_motion_or_code(reader, "a");
  request.b = read_motion_or_code(reader, "b");
  request.c = read_motion_or_code(reader, "c");
  reader.read("decoder", request.decoder);
  reader.finish();
  return request;
}

DenoiseRequest denoise_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  DenoiseRequest request;
  reader.read("model", request.model);
  request.motions = read_motions(reader, "motions");
  reader.read("decoder", request.decoder);
  reader.read("zeros_are_missing", request.zeros_are_missing);
  reader.read("means_are_missing", request.means_are_missing);
  reader.read("iterations", request.iterations);
  reader.read("keep_observed", request.keep_observed);
  reader.finish();
  return request;
}

JobSpec job_spec_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  JobSpec spec;
  reader.read("dataset", spec.dataset);
  reader.read("variant", spec.variant);
  if (const json* config = reader.find("config")) {
    if (!config->is_object()) throw type_error("config", "an object (the training configuration)", *config);
    spec.config_json = config->dump();
  }
  reader.read("iterations", spec.iterations);
  reader.read("seed", spec.seed);
  reader.read("hidden", spec.hidden);
  reader.read("batch", spec.batch);
  reader.read("model_name", spec.model_name);
  reader.finish();
  return spec;
}

void empty_request_from_json(const std::string& body) {
  if (body.find_first_not_of(" \t\r\n") == std::string::npos) return;
  const json document = parse_body(body);
  ObjectReader(document, "").finish();
}

std::string encode_reply_to_json(const EncodeReply& reply) {
  FloatJson codes = FloatJson::array();
  for (const Code& code : reply.codes) codes.push_back(code_json(code));
  return dump(FloatJson{{"answered_by", answered_by_json(reply.answered_by)}, {"codes", std::move(codes)}});
}

std::string motions_reply_to_json(const MotionsReply& reply) {
  FloatJson motions = FloatJson::array();
  for (const Motion& motion : reply.motions) motions.push_back(motion_json(motion));
  FloatJson codes = FloatJson::array();
  for (const Code& code : reply.codes) codes.push_back(code_json(code));
  return dump(FloatJson{{"answered_by", answered_by_json(reply.answered_by)},
                        {"motions", std::move(motions)},
                        {"codes", std::move(codes)}});
}

std::string model_info_to_json(const ModelInfo& model) { return dump(model_json(model)); }

std::string model_list_to_json(const std::vector<ModelInfo>& models) {
  json list = json::array();
  for (const ModelInfo& model : models) list.push_back(model_json(model));
  return dump(json{{"models", std::move(list)}});
}

json clip_file_json(const ClipFile& clip) {
  return json{{"path", clip.path}, {"format", clip.format}, {"size_bytes", clip.size_bytes}, {"uploaded", clip.uploaded}};
}

std::string clip_list_to_json(const ListClipsReply& reply) {
  json clips = json::array();
  for (const ClipFile& clip : reply.clips) clips.push_back(clip_file_json(clip));
  return dump(json{{"clips", std::move(clips)}, {"truncated", reply.truncated}});
}

std::string clip_file_to_json(const ClipFile& clip) { return dump(clip_file_json(clip)); }

std::string read_clip_reply_to_json(const ReadClipReply& reply) {
  return dump(FloatJson{{"path", reply.path},
                        {"format", reply.format},
                        {"start", reply.start},
                        {"file_frames", reply.file_frames},
                        {"file_frame_rate", reply.file_frame_rate},
                        {"last_start", reply.last_start},
                        {"motion", motion_json(reply.motion)}});
}

std::string job_info_to_json(const JobInfo& job) { return dump(job_json(job)); }

std::string job_list_to_json(const std::vector<JobInfo>& jobs) {
  json list = json::array();
  for (const JobInfo& job : jobs) list.push_back(job_json(job));
  return dump(json{{"jobs", std::move(list)}});
}

namespace {

FloatJson take_windows_json(const std::vector<TakeWindow>& windows) {
  FloatJson list = FloatJson::array();
  for (const TakeWindow& window : windows) {
    list.push_back(FloatJson{{"start_seconds", window.start_seconds},
                             {"start_frame", window.start_frame},
                             {"code", code_json(window.code)}});
  }
  return list;
}

}  // namespace

DecodeTrackRequest decode_track_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  ObjectReader reader(document, "");
  DecodeTrackRequest request;
  reader.read("model", request.model);
  if (const json* v = reader.find("windows")) {
    const std::string path = reader.path("windows");
    if (!v->is_array()) throw type_error(path, "an array of windows ({\"start_seconds\", \"code\"})", *v);
    for (size_t i = 0; i < v->size(); ++i) {
      ObjectReader window_reader((*v)[i], index_path(path, i));
      TakeWindow window;
      window_reader.read("start_seconds", window.start_seconds);
      window_reader.read("start_frame", window.start_frame);  // as encode gives it; not read
      if (const json* code = window_reader.find("code")) window.code = read_floats(*code, window_reader.path("code"));
      window_reader.finish();
      request.windows.push_back(std::move(window));
    }
  }
  reader.read("frame_rate", request.frame_rate);
  reader.read("frames", request.frames);
  reader.read("decoder", request.decoder);
  reader.read("blend", request.blend);
  reader.finish();
  return request;
}

std::string code_track_to_json(const GatheredTake& take) {
  return dump(FloatJson{{"answered_by", answered_by_json(take.start.answered_by)},
                        {"frames", take.summary.input_frames},
                        {"frame_rate", take.summary.input_frame_rate},
                        {"window_seconds", take.summary.window_seconds},
                        {"hop_seconds", take.summary.hop_seconds},
                        {"windows", take_windows_json(take.windows)}});
}

std::string take_reply_to_json(const GatheredTake& take) {
  const int64_t frames = take.start.columns > 0 ? static_cast<int64_t>(take.values.size()) / take.start.columns : 0;
  return dump(FloatJson{{"answered_by", answered_by_json(take.start.answered_by)},
                        {"frame_rate", take.start.frame_rate},
                        {"frames", frames},
                        {"columns", take.start.columns},
                        {"layout", take.start.layout},
                        {"values", take.values},
                        {"error_mm", take.error_mm},
                        {"summary", FloatJson{{"frames", take.summary.frames},
                                              {"input_frames", take.summary.input_frames},
                                              {"mean_error_mm", take.summary.mean_error_mm},
                                              {"max_error_mm", take.summary.max_error_mm},
                                              {"window_seconds", take.summary.window_seconds},
                                              {"hop_seconds", take.summary.hop_seconds}}},
                        {"windows", take_windows_json(take.windows)}});
}

}  // namespace mm::service::rest
