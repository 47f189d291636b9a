// The proto's messages as the REST frontend's JSON (server/rest/README.md):
// the same snake_case names, a code as a bare array, JSON-text fields
// (config_json, provenance_json, evaluation_json) as embedded objects. Used
// both to talk REST and to print any reply with --json, so that both
// protocols print the same document.
#pragma once

#include <nlohmann/json.hpp>

#include "motionmanifold/v1/manifold.pb.h"

namespace mm::client {

namespace v1 = motionmanifold::v1;
using nlohmann::json;

// Requests, as the REST routes take them. Where the proto's zero value means
// "the default" (count, steps, method, iterations, variant) the field is left
// out, which is how REST asks for the default (a REST 0 is taken as 0).
json to_json(const v1::EncodeRequest& request);
json to_json(const v1::DecodeRequest& request);
json to_json(const v1::SampleRequest& request);
json to_json(const v1::InterpolateRequest& request);
json to_json(const v1::AnalogyRequest& request);
json to_json(const v1::DenoiseRequest& request);
json to_json(const v1::JobSpec& spec);
json to_json(const v1::DecodeTrackRequest& request);

// Replies, as the REST routes answer them.
json to_json(const v1::EncodeReply& reply);
json to_json(const v1::MotionsReply& reply);
json to_json(const v1::ModelInfo& model);
json to_json(const v1::ListModelsReply& reply);
json to_json(const v1::ClipFile& clip);
json to_json(const v1::ListClipsReply& reply);
json to_json(const v1::ReadClipReply& reply);
json to_json(const v1::Job& job);
json to_json(const v1::ListJobsReply& reply);
// A code track as POST /v1/takes:encode answers it, which is also the code
// track file `take encode` writes and `track decode` reads.
json to_json(const v1::CodeTrack& track);
// A take's summary as the "summary" of a take's JSON reply, with the
// reply's "windows" beside it: {"summary": {...}, "windows": [...]}.
json to_json(const v1::TakeSummary& summary);

// REST replies back into the proto's messages. Throw nlohmann::json's
// exceptions when a field has the wrong type (a server of another version).
v1::EncodeReply encode_reply_from_json(const json& body);
v1::MotionsReply motions_reply_from_json(const json& body);
v1::ModelInfo model_from_json(const json& body);
v1::ListModelsReply models_from_json(const json& body);
v1::ClipFile clip_file_from_json(const json& body);
v1::ListClipsReply clips_from_json(const json& body);
v1::ReadClipReply clip_window_from_json(const json& body);
v1::Job job_from_json(const json& body);
v1::ListJobsReply jobs_from_json(const json& body);
v1::CodeTrack code_track_from_json(const json& body);
// A take's JSON reply (POST /v1/takes:reconstruct, :denoise, /v1/tracks:decode)
// as the messages of its gRPC stream: header, its frames as one chunk, summary.
v1::TakeOutputHeader take_header_from_json(const json& body);
v1::FrameChunk take_frames_from_json(const json& body);
v1::TakeSummary take_summary_from_json(const json& body);

}  // namespace mm::client
