// Translation between the wire messages of motionmanifold.v1 and the core
// API's plain types (api/api_types.h), one function per message, for both
// frontends: gRPC translates its messages as they come; REST reads its JSON
// into the same messages first (wire/rest_json.h) and then translates them
// here. Fields map one to one under the same names; nothing is validated
// here (the core validates, once for both protocols).
//
// Proto3 cannot tell an unset field from one set to its zero value, so where
// the core's default is not the zero value (SampleRequest.count,
// InterpolateRequest.steps and method, DenoiseRequest.iterations,
// JoinClipsRequest.transition_seconds and method, JobSpec.variant) the zero value stands for the core's default; every other
// value, zero included, reaches the core as sent. (REST can tell them apart
// and reads a zero that is there as zero: server/rest/json_translation.cpp.)
//
// Thread safety: pure functions of their arguments.
#pragma once

#include "motionmanifold/v1/manifold.pb.h"
#include "server/api/api_types.h"
#include "server/core/take_session.h"

namespace mm::service::proto_translation {

namespace v1 = ::motionmanifold::v1;

// Wire -> core.
Motion to_api(const v1::Motion& motion);
Code to_api(const v1::Code& code);
MotionOrCode to_api(const v1::MotionOrCode& either);
EncodeRequest to_api(const v1::EncodeRequest& request);
DecodeRequest to_api(const v1::DecodeRequest& request);
SampleRequest to_api(const v1::SampleRequest& request);
InterpolateRequest to_api(const v1::InterpolateRequest& request);
AnalogyRequest to_api(const v1::AnalogyRequest& request);
DenoiseRequest to_api(const v1::DenoiseRequest& request);
JoinClipsRequest to_api(const v1::JoinClipsRequest& request);
ReadClipRequest to_api(const v1::ReadClipRequest& request);
UploadClipRequest to_api(const v1::UploadClipRequest& request);
JobSpec to_api(const v1::JobSpec& spec);
TakeRequest to_api(const v1::TakeHeader& header);
TakeWindow to_api(const v1::TakeWindow& window);
DecodeTrackRequest to_api(const v1::DecodeTrackRequest& request);

// Core -> wire: each fills `out` (cleared first).
void to_wire(const Motion& motion, v1::Motion* out);
void to_wire(const Code& code, v1::Code* out);
void to_wire(const AnsweredBy& answered_by, v1::AnsweredBy* out);
void to_wire(const EncodeReply& reply, v1::EncodeReply* out);
void to_wire(const MotionsReply& reply, v1::MotionsReply* out);
void to_wire(const JoinClipsReply& reply, v1::JoinClipsReply* out);
void to_wire(const ModelInfo& info, v1::ModelInfo* out);
void to_wire(const ClipFile& clip, v1::ClipFile* out);
void to_wire(const ListClipsReply& reply, v1::ListClipsReply* out);
void to_wire(const ReadClipReply& reply, v1::ReadClipReply* out);
void to_wire(const JobSpec& spec, v1::JobSpec* out);
void to_wire(const JobProgress& progress, v1::JobProgress* out);
void to_wire(const JobInfo& info, v1::Job* out);
void to_wire(const TakeWindow& window, v1::TakeWindow* out);
void to_wire(const TakeReplyStart& start, v1::TakeOutputHeader* out);
// A code track's take: its frames and rate, window length and hop (its
// answered_by and windows apart, as they come).
void to_wire(const TakeSummary& summary, v1::CodeTrack* out);
// A take's reply summary: the frames answered (output_frames), the input's
// frames, the errors, window and hop, and the gap fill's counts (the windows
// apart, as they come).
void to_wire(const TakeSummary& summary, v1::TakeSummary* out);

}  // namespace mm::service::proto_translation
