// The REST JSON of every request and reply body (server/rest/README.md,
// "JSON"), as a second encoding of the proto's messages
// (proto/motionmanifold/v1/manifold.proto): the client writes a request and
// reads its reply with these functions, the server reads the request and
// writes the reply with the same ones, so the two cannot disagree on a name
// or a shape.
//
// The encoding is the proto's field for field under the same snake_case
// names, with these differences:
// - a Code is a bare array of numbers, and `from`, `to`, `a`, `b`, `c` are
//   {"motion": {...}} or {"code": [...]};
// - a field holding JSON text (JobSpec.config_json, ModelInfo's
//   provenance_json, evaluation_json and skeleton_json) holds the object
//   itself, named without "_json" ("config", "provenance", ...);
// - where the proto's zero value means "the default" (SampleRequest.count,
//   InterpolateRequest.steps and method, DenoiseRequest.iterations,
//   JoinClipsRequest.transition_seconds and method, JobSpec.variant) a zero value is left out, which is how REST asks for the
//   default (REST reads a 0 that is there as 0: the server's business,
//   server/rest/json_translation.cpp);
// - a POST /v1/jobs body is the JobSpec itself; a take's JSON reply is
//   TakeReply below; DecodeTrackRequest's windows carry no start_frame (the
//   server does not read it).
//
// Documents holding motions or codes are FloatJson: each number is written
// in its shortest form that reads back to the same float32 ("0.106", not the
// 17 digits of the double), a third of the size, and a non-finite one as
// proto3's JSON mapping spells it ("NaN", "Infinity", "-Infinity": a missing
// value of a take read whole stays NaN). Their other numbers (a
// motion's frame_rate, a take's seconds) are float32 too, as the server has
// always written them. The other documents are nlohmann::json.
//
// Reading (from_json) takes a parsed document and fills the message
// (cleared first); it throws InputError (format/input_error.h) naming the
// field. Requests are read refusing unknown members, replies ignoring them
// (`unknown`).
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "motionmanifold/v1/manifold.pb.h"
#include "wire/json_fields.h"

namespace mm::wire {

namespace v1 = ::motionmanifold::v1;
using Json = nlohmann::json;
using FloatJson = nlohmann::basic_json<std::map, std::vector, std::string, bool, std::int64_t, std::uint64_t, float>;

// A take's JSON reply (POST /v1/takes:reconstruct, :denoise, /v1/tracks:decode):
// the messages of its gRPC stream with all its frames in one chunk,
//   {"answered_by", "frame_rate", "columns", "layout" (the header),
//    "frames", "values", "error_mm" (the chunk),
//    "summary": {"frames", "input_frames", "mean_error_mm", "max_error_mm",
//                "window_seconds", "hop_seconds"}, "windows" (the summary)}.
struct TakeReply {
  v1::TakeOutputHeader header;
  v1::FrameChunk frames;
  v1::TakeSummary summary;
};

// ---- Requests (the client writes them, the server reads them)
FloatJson to_json(const v1::EncodeRequest& request);
Json to_json(const v1::SampleRequest& request);
FloatJson to_json(const v1::DecodeRequest& request);
FloatJson to_json(const v1::InterpolateRequest& request);
FloatJson to_json(const v1::AnalogyRequest& request);
FloatJson to_json(const v1::DenoiseRequest& request);
FloatJson to_json(const v1::JoinClipsRequest& request);
Json to_json(const v1::JobSpec& spec);  // also a Job's "spec"
FloatJson to_json(const v1::DecodeTrackRequest& request);

void from_json(const Json& body, v1::EncodeRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::SampleRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::DecodeRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
// A motion and a code both given is refused naming the field ("from"): the
// proto's oneof holds one.
void from_json(const Json& body, v1::InterpolateRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::AnalogyRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::DenoiseRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
// `a` and `b` are motions themselves, as in the proto: {"a": {"frames", ...}}.
void from_json(const Json& body, v1::JoinClipsRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::JobSpec& out, UnknownFields unknown = UnknownFields::kRefuse);
void from_json(const Json& body, v1::DecodeTrackRequest& out, UnknownFields unknown = UnknownFields::kRefuse);
// The body of a call that takes no fields (activate, cancel): {}.
void empty_from_json(const Json& body, UnknownFields unknown = UnknownFields::kRefuse);

// ---- Replies (the server writes them, the client reads them)
FloatJson to_json(const v1::EncodeReply& reply);
FloatJson to_json(const v1::MotionsReply& reply);
// {"answered_by", "motion", "transition_first_frame", "transition_last_frame"}
FloatJson to_json(const v1::JoinClipsReply& reply);
Json to_json(const v1::ModelInfo& model);
Json to_json(const v1::ListModelsReply& reply);  // {"models": [...]}
Json to_json(const v1::ClipFile& clip);
Json to_json(const v1::ListClipsReply& reply);  // {"clips": [...], "truncated"}
FloatJson to_json(const v1::ReadClipReply& reply);
Json to_json(const v1::Job& job);               // also each event of GET /v1/jobs/{id}/events
Json to_json(const v1::ListJobsReply& reply);   // {"jobs": [...]}
FloatJson to_json(const v1::CodeTrack& track);  // POST /v1/takes:encode; the client's code track file
FloatJson to_json(const TakeReply& reply);
// The summary part of a take's reply: {"summary": {...}, "windows": [...]}.
FloatJson to_json(const v1::TakeSummary& summary);

void from_json(const Json& body, v1::EncodeReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::MotionsReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::JoinClipsReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ModelInfo& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ListModelsReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ClipFile& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ListClipsReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ReadClipReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::Job& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::ListJobsReply& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, v1::CodeTrack& out, UnknownFields unknown = UnknownFields::kIgnore);
void from_json(const Json& body, TakeReply& out, UnknownFields unknown = UnknownFields::kIgnore);

// A document as the compact text of a body. Bytes that are not UTF-8 (a
// name a client sent) are written as U+FFFD rather than fail the reply.
std::string body_text(const Json& document);
std::string body_text(const FloatJson& document);

}  // namespace mm::wire
