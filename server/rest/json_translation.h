// REST JSON bodies <-> the core's plain types (api/api_types.h). The JSON is
// read into the proto's messages and written from them by the code the
// client writes and reads it with (wire/rest_json.h), and the messages are
// translated as gRPC's are (translation/proto_translation.h), so REST and
// gRPC, server and client, share one definition of every field. What is
// REST's alone is here:
// - the body's text parsed: INVALID_ARGUMENT with field "" and the parser's
//   position for a body that does not parse, or that nests deeper than
//   kMaxJsonDepth;
// - a field the wire code cannot read (wrong JSON type, unknown field,
//   integer out of range) answered as INVALID_ARGUMENT naming its path
//   ("motions[0].values[12]", "from.motion.frames") and what was expected;
// - REST tells a field left out from one sent as zero, which proto3 cannot:
//   a `count`, `steps`, `method`, `iterations`, `transition_seconds` or
//   `variant` that is there
//   reaches the core as sent (a REST 0 is 0, refused by the core naming it),
//   one left out or null takes the core's default.
// Values in range, lengths, model names: the core's to check.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <string>
#include <vector>

#include "server/api/api_types.h"
#include "server/core/take_session.h"

namespace mm::service::rest {

// Request bodies (the body's text). Throw ApiError INVALID_ARGUMENT.
EncodeRequest encode_request_from_json(const std::string& body);
DecodeRequest decode_request_from_json(const std::string& body);
SampleRequest sample_request_from_json(const std::string& body);
InterpolateRequest interpolate_request_from_json(const std::string& body);
AnalogyRequest analogy_request_from_json(const std::string& body);
DenoiseRequest denoise_request_from_json(const std::string& body);
// {"model", "a": {motion}, "b": {motion}, "transition_seconds", "method", "decoder"}
JoinClipsRequest join_clips_request_from_json(const std::string& body);
JobSpec job_spec_from_json(const std::string& body);
// {"model", "windows": [{"start_seconds", "code"}], "frame_rate", "frames", "decoder", "blend"}
DecodeTrackRequest decode_track_request_from_json(const std::string& body);
// The body of a call that takes no fields (activate, cancel): empty or {}.
void empty_request_from_json(const std::string& body);

// Reply bodies (compact JSON text). Floats of motions and codes are written
// in their shortest form that reads back to the same float.
std::string encode_reply_to_json(const EncodeReply& reply);
std::string motions_reply_to_json(const MotionsReply& reply);
std::string join_clips_reply_to_json(const JoinClipsReply& reply);
std::string model_info_to_json(const ModelInfo& model);
std::string model_list_to_json(const std::vector<ModelInfo>& models);  // {"models": [...]}
std::string clip_list_to_json(const ListClipsReply& reply);     // {"clips": [...], "truncated": false}
std::string clip_file_to_json(const ClipFile& clip);            // {"path", "format", "size_bytes", "uploaded"}
std::string read_clip_reply_to_json(const ReadClipReply& reply);  // {"path", ..., "motion": {...}}
std::string job_info_to_json(const JobInfo& job);
std::string job_list_to_json(const std::vector<JobInfo>& jobs);  // {"jobs": [...]}
// The take routes' replies are written in take_routes.cpp, from the
// messages they gather (wire/rest_json.h's CodeTrack and TakeReply).

}  // namespace mm::service::rest
