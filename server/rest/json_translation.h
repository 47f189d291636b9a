// JSON <-> the core's plain types (api/api_types.h) for the REST frontend.
// Field names are the C++ members' (snake_case), the same as the proto's.
// Where the C++ type holds JSON text (JobSpec::config_json,
// ModelInfo::provenance_json / evaluation_json), the REST field carries the
// JSON object itself, named without "_json": "config", "provenance",
// "evaluation".
//
// Reading is lenient where proto3's JSON mapping is: an absent or null field
// takes the C++ default, a float may be the string "NaN", "Infinity" or
// "-Infinity", and a 64-bit integer (seed, iterations) a decimal string. It is
// strict about what JSON itself can get wrong: a body that does not parse is
// INVALID_ARGUMENT with field "" and the parser's position; a field of the
// wrong JSON type, or an unknown field, is INVALID_ARGUMENT naming the field's
// path ("motions[0].values[12]", "from.motion.frames") and the expected
// type. Values in range, lengths, model names: the core's to check.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <string>
#include <vector>

#include "api/api_types.h"
#include "core/take_session.h"

namespace mm::service::rest {

// Request bodies (the body's text). Throw ApiError INVALID_ARGUMENT.
EncodeRequest encode_request_from_json(const std::string& body);
DecodeRequest decode_request_from_json(const std::string& body);
SampleRequest sample_request_from_json(const std::string& body);
InterpolateRequest interpolate_request_from_json(const std::string& body);
AnalogyRequest analogy_request_from_json(const std::string& body);
DenoiseRequest denoise_request_from_json(const std::string& body);
JobSpec job_spec_from_json(const std::string& body);
// The body of a call that takes no fields (activate, cancel): empty or {}.
void empty_request_from_json(const std::string& body);

// Reply bodies (compact JSON text). Floats of motions and codes are written
// in their shortest form that reads back to the same float.
std::string encode_reply_to_json(const EncodeReply& reply);
std::string motions_reply_to_json(const MotionsReply& reply);
std::string model_info_to_json(const ModelInfo& model);
std::string model_list_to_json(const std::vector<ModelInfo>& models);  // {"models": [...]}
std::string clip_list_to_json(const ListClipsReply& reply);     // {"clips": [...], "truncated": false}
std::string clip_file_to_json(const ClipFile& clip);            // {"path", "format", "size_bytes"}
std::string read_clip_reply_to_json(const ReadClipReply& reply);  // {"path", ..., "motion": {...}}
std::string job_info_to_json(const JobInfo& job);
std::string job_list_to_json(const std::vector<JobInfo>& jobs);  // {"jobs": [...]}

// Takes (POST /v1/takes:*, /v1/tracks:decode): a reply gathered whole, as
// REST answers it after the take's end.
struct GatheredTake {
  TakeReplyStart start;
  std::vector<TakeWindow> windows;
  std::vector<float> values;    // frames x start.columns
  std::vector<float> error_mm;  // one a frame; empty for a decoded track
  TakeSummaryReply summary;
};
// {"model", "windows": [{"start_seconds", "code"}], "frame_rate", "frames", "decoder", "blend"}
DecodeTrackRequest decode_track_request_from_json(const std::string& body);
// {"answered_by", "frames", "frame_rate", "window_seconds", "hop_seconds", "windows": [...]}
std::string code_track_to_json(const GatheredTake& take);
// {"answered_by", "frame_rate", "frames", "columns", "layout", "values", "error_mm", "summary", "windows"}
std::string take_reply_to_json(const GatheredTake& take);

}  // namespace mm::service::rest
