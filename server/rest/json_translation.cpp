#include "server/rest/json_translation.h"

#include <nlohmann/json.hpp>

#include "format/input_error.h"
#include "format/json_text.h"
#include "server/translation/proto_translation.h"
#include "wire/rest_json.h"

namespace mm::service::rest {

namespace {

using json = nlohmann::json;
namespace v1 = ::motionmanifold::v1;

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
    // A BVH file sent without its type (curl -d @walk.bvh says
    // application/x-www-form-urlencoded) is read as JSON: say what to send.
    const size_t first = body.find_first_not_of(" \t\r\n");
    const bool bvh = first != std::string::npos && body.compare(first, 9, "HIERARCHY") == 0;
    throw ApiError(ErrorCode::kInvalidArgument, "",
                   "malformed JSON" + (syntax ? " (byte " + std::to_string(syntax->byte) + ")" : std::string()) + ": " +
                       what +
                       (bvh ? "; the body is a BVH file: send it with Content-Type: application/x-bvh" : ""));
  }
}

// The request message read from the parsed body, a field the wire code
// cannot read answered as INVALID_ARGUMENT naming it.
template <typename Message>
Message read_message(const json& document) {
  Message message;
  try {
    ::mm::wire::from_json(document, message);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, error.field(), error.detail());
  }
  return message;
}

// Where proto3's zero means the core's default, REST's zero is a zero when
// the body has the field: `field` takes the value sent.
template <typename T, typename Sent>
void keep_sent_zero(const json& document, const char* key, const Sent& sent, T& field) {
  const auto it = document.find(key);
  if (it != document.end() && !it->is_null()) field = sent;
}

template <typename Message, typename Api>
std::string reply_text(const Api& reply) {
  Message message;
  proto_translation::to_wire(reply, &message);
  return ::mm::wire::body_text(::mm::wire::to_json(message));
}

}  // namespace

EncodeRequest encode_request_from_json(const std::string& body) {
  return proto_translation::to_api(read_message<v1::EncodeRequest>(parse_body(body)));
}

DecodeRequest decode_request_from_json(const std::string& body) {
  return proto_translation::to_api(read_message<v1::DecodeRequest>(parse_body(body)));
}

SampleRequest sample_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  const auto message = read_message<v1::SampleRequest>(document);
  SampleRequest request = proto_translation::to_api(message);
  keep_sent_zero(document, "count", message.count(), request.count);
  return request;
}

InterpolateRequest interpolate_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  const auto message = read_message<v1::InterpolateRequest>(document);
  InterpolateRequest request = proto_translation::to_api(message);
  keep_sent_zero(document, "steps", message.steps(), request.steps);
  keep_sent_zero(document, "method", message.method(), request.method);
  return request;
}

AnalogyRequest analogy_request_from_json(const std::string& body) {
  return proto_translation::to_api(read_message<v1::AnalogyRequest>(parse_body(body)));
}

DenoiseRequest denoise_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  const auto message = read_message<v1::DenoiseRequest>(document);
  DenoiseRequest request = proto_translation::to_api(message);
  keep_sent_zero(document, "iterations", message.iterations(), request.iterations);
  return request;
}

JoinClipsRequest join_clips_request_from_json(const std::string& body) {
  const json document = parse_body(body);
  const auto message = read_message<v1::JoinClipsRequest>(document);
  JoinClipsRequest request = proto_translation::to_api(message);
  keep_sent_zero(document, "transition_seconds", message.transition_seconds(), request.transition_seconds);
  keep_sent_zero(document, "method", message.method(), request.method);
  return request;
}

JobSpec job_spec_from_json(const std::string& body) {
  const json document = parse_body(body);
  const auto message = read_message<v1::JobSpec>(document);
  JobSpec spec = proto_translation::to_api(message);
  keep_sent_zero(document, "variant", message.variant(), spec.variant);
  return spec;
}

DecodeTrackRequest decode_track_request_from_json(const std::string& body) {
  return proto_translation::to_api(read_message<v1::DecodeTrackRequest>(parse_body(body)));
}

void empty_request_from_json(const std::string& body) {
  if (body.find_first_not_of(" \t\r\n") == std::string::npos) return;
  const json document = parse_body(body);
  try {
    ::mm::wire::empty_from_json(document);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, error.field(), error.detail());
  }
}

std::string encode_reply_to_json(const EncodeReply& reply) { return reply_text<v1::EncodeReply>(reply); }
std::string motions_reply_to_json(const MotionsReply& reply) { return reply_text<v1::MotionsReply>(reply); }
std::string join_clips_reply_to_json(const JoinClipsReply& reply) { return reply_text<v1::JoinClipsReply>(reply); }
std::string model_info_to_json(const ModelInfo& model) { return reply_text<v1::ModelInfo>(model); }
std::string clip_list_to_json(const ListClipsReply& reply) { return reply_text<v1::ListClipsReply>(reply); }
std::string clip_file_to_json(const ClipFile& clip) { return reply_text<v1::ClipFile>(clip); }
std::string read_clip_reply_to_json(const ReadClipReply& reply) { return reply_text<v1::ReadClipReply>(reply); }
std::string job_info_to_json(const JobInfo& job) { return reply_text<v1::Job>(job); }

std::string model_list_to_json(const std::vector<ModelInfo>& models) {
  v1::ListModelsReply reply;
  for (const ModelInfo& model : models) proto_translation::to_wire(model, reply.add_models());
  return ::mm::wire::body_text(::mm::wire::to_json(reply));
}

std::string job_list_to_json(const std::vector<JobInfo>& jobs) {
  v1::ListJobsReply reply;
  for (const JobInfo& job : jobs) proto_translation::to_wire(job, reply.add_jobs());
  return ::mm::wire::body_text(::mm::wire::to_json(reply));
}

}  // namespace mm::service::rest
