#include "server/rest/take_routes.h"

#include <httplib.h>

#include <algorithm>
#include <cstdio>
#include <memory>
#include <sstream>

#include "format/input_error.h"
#include "format/motion_text.h"
#include "format/skeleton_bvh.h"
#include "server/rest/body_for_model.h"
#include "server/rest/bvh_translation.h"
#include "server/rest/json_translation.h"
#include "server/rest/query_translation.h"
#include "server/translation/proto_translation.h"
#include "wire/rest_json.h"

namespace mm::service::rest {
namespace {

constexpr const char* kJsonType = "application/json";
constexpr const char* kTextType = "text/plain";

// What the reply's body is, by Accept: the JSON of the proto's messages
// (the default), motion text, or an animation file (BVH, glTF).
struct ReplyForm {
  bool json = true;
  bool animation = false;
  AnimationFormat animation_format = AnimationFormat::kBvh;
};

bool names_text(const std::string& accept) {
  std::string lower = accept;
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return std::tolower(c); });
  return lower.find(kTextType) != std::string::npos;
}

// Decided before the call, so that the frames are gathered once into what
// writes them, and an Accept never answered is refused before any work.
ReplyForm reply_form(const httplib::Request& request) {
  const std::string accept = request.get_header_value("Accept");
  ReplyForm form;
  form.animation = names_animation(accept, &form.animation_format);
  if (form.animation && form.animation_format == AnimationFormat::kFbx) {
    throw ApiError(ErrorCode::kInvalidArgument, "Accept",
                   "application/octet-stream (FBX) is read, never written: ask for application/x-bvh, "
                   "model/gltf-binary, model/gltf+json, text/plain or application/json");
  }
  form.json = !form.animation && !names_text(accept);
  return form;
}

// A take's reply gathered whole, as REST answers it after the take's end:
// for JSON into the messages its writer reads, otherwise into the frames
// the text and animation writers read, and the core's summary for the
// X-Take-* headers.
struct GatheredTake {
  ReplyForm form;
  ::mm::wire::TakeReply reply;  // the header and the windows always; the frames for JSON
  MotionFrames frames;          // the frames for text and animation files
  TakeSummary summary;
};

// The core's reply gathered into `take`.
TakeReplySink gathering_sink(GatheredTake& take) {
  TakeReplySink sink;
  sink.on_start = [&take](const TakeReplyStart& start) {
    proto_translation::to_wire(start, &take.reply.header);
    take.frames.columns = start.columns;
  };
  sink.on_window = [&take](const TakeWindow& window) {
    proto_translation::to_wire(window, take.reply.summary.add_windows());
  };
  sink.on_frames = [&take](const float* values, const float* error_mm, int64_t count) {
    const int64_t size = count * take.frames.columns;
    if (take.form.json) {
      take.reply.frames.mutable_values()->Add(values, values + size);
      if (error_mm != nullptr) take.reply.frames.mutable_error_mm()->Add(error_mm, error_mm + count);
    } else {
      take.frames.values.insert(take.frames.values.end(), values, values + size);
    }
  };
  return sink;
}

// The summary once the core has answered: the reply's frame count and the
// summary's fields beside the windows gathered.
void finish(GatheredTake& take, const TakeSummary& summary) {
  take.summary = summary;
  proto_translation::to_wire(summary, &take.reply.summary);
  const int columns = take.frames.columns;
  take.reply.frames.set_frames(take.form.json ? (columns > 0 ? take.reply.frames.values_size() / columns : 0)
                                              : take.frames.frame_count());
}

std::string decimal(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.6g", value);
  return text;
}

// The reply's frames in the form asked for, with the summary in X-Take-*
// headers for the forms that have no room for it.
void send_frames(const GatheredTake& take, const ModelShape& shape, httplib::Response& response) {
  response.status = 200;
  if (take.form.json) {
    return response.set_content(::mm::wire::body_text(::mm::wire::to_json(take.reply)), kJsonType);
  }
  const MotionFrames& frames = take.frames;
  response.set_header("X-Take-Frames", std::to_string(frames.frame_count()));
  response.set_header("X-Take-Frame-Rate", decimal(take.reply.header.frame_rate()));
  response.set_header("X-Take-Mean-Error-Mm", decimal(take.summary.mean_error_mm));
  response.set_header("X-Take-Max-Error-Mm", decimal(take.summary.max_error_mm));
  response.set_header("X-Take-Windows", std::to_string(take.summary.windows));
  // DenoiseTake with keep_observed: the windows fitted to its gaps, the
  // gaps they held, the gaps left to the matched fill (0 otherwise).
  response.set_header("X-Take-Gap-Windows-Fitted", std::to_string(take.summary.gap_windows_fitted));
  response.set_header("X-Take-Gaps-Fitted", std::to_string(take.summary.gaps_fitted));
  response.set_header("X-Take-Gaps-Over-Fit-Limit", std::to_string(take.summary.gaps_over_fit_limit));
  if (take.form.animation) {
    try {
      return response.set_content(
          write_animation_file(skeleton_motion_to_bvh(shape.skeleton, bvh_layout_of(shape.skeleton), frames,
                                                      take.reply.header.frame_rate()),
                               take.form.animation_format, bvh_layout_of(shape.skeleton).millimetres_per_unit),
          animation_format_media_type(take.form.animation_format));
    } catch (const InputError& error) {
      throw ApiError(ErrorCode::kInternal, "", std::string("the reply cannot be written as BVH: ") + error.what());
    }
  }
  std::ostringstream text;
  write_motion_text(frames, text);
  response.set_content(text.str(), kTextType);
}

// The format of an animation body; application/octet-stream's by its
// first bytes (FBX or glTF binary).
AnimationFormat sniffed_body_format(const std::string& body, AnimationFormat named) {
  try {
    return animation_body_format(body, named, "request body");
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, "body", error.what());
  }
}

TakeOperation operation_of(RouteId route) {
  switch (route) {
    case RouteId::kEncodeTake: return TakeOperation::kEncode;
    case RouteId::kDenoiseTake: return TakeOperation::kDenoise;
    default: return TakeOperation::kReconstruct;
  }
}

}  // namespace

void answer_take(Core& core, RouteId route, const CallContext& context, const httplib::Request& request,
                 const std::string& body, httplib::Response& response) {
  // The model is chosen first (Core::choose_model), then a body is read in
  // its columns or skeleton, the core's operation runs on it, and the reply
  // is written for its shape (a BVH reply is of its skeleton): an activation
  // meanwhile changes none of them. What the Accept header asks for is
  // checked before any of it.
  GatheredTake take;
  if (route == RouteId::kDecodeTrack) {
    const DecodeTrackRequest track = decode_track_request_from_json(body);
    take.form = reply_form(request);
    const ChosenModel chosen = core.choose_model(context, "decode_track", track.model);
    finish(take, core.decode_track(context, track, gathering_sink(take), chosen));
    return send_frames(take, chosen.shape(), response);
  }
  const TakeOperation operation = operation_of(route);
  AnimationFormat body_format = AnimationFormat::kBvh;
  const bool bvh_body = names_animation(request.get_header_value("Content-Type"), &body_format);
  TakeRequest take_request = take_request_from_query(request.params, operation == TakeOperation::kDenoise, bvh_body);
  if (take_request.path.empty() && body.empty()) {
    throw ApiError(ErrorCode::kInvalidArgument, "body",
                   "the body is empty, expected the take (motion text, or BVH with Content-Type: "
                   "application/x-bvh) or path=<a file under the data root>");
  }
  if (!take_request.path.empty() && !body.empty()) {
    throw ApiError(ErrorCode::kInvalidArgument, "body",
                   "a take named by path= has an empty body, found " + std::to_string(body.size()) + " bytes");
  }
  // The code track is JSON whatever Accept says.
  if (operation != TakeOperation::kEncode) take.form = reply_form(request);
  const ChosenModel chosen = core.choose_model(context, take_call_name(operation), take_request.model);
  TakeChunkReader read;  // none for a take named by path=, which the core reads
  if (take_request.path.empty()) {
    auto file = std::make_shared<const TakeFile>(read_body_for_model(core, chosen, [&](const ModelShape& shape) {
      return bvh_body ? take_from_bvh(body, "request body", "body", shape.skeleton,
                                      sniffed_body_format(body, body_format))
                      : take_from_text(body, "request body", "body", shape.columns, take_request.frame_rate,
                                       operation == TakeOperation::kDenoise);
    }));
    take_request.frame_rate = file->frame_rate;
    read = take_file_reader(std::move(file));
  }
  const TakeSummary summary = core.run_take(context, operation, take_request, read, gathering_sink(take), chosen);
  if (operation == TakeOperation::kEncode) {
    ::motionmanifold::v1::CodeTrack track;
    *track.mutable_answered_by() = take.reply.header.answered_by();
    track.mutable_windows()->Swap(take.reply.summary.mutable_windows());
    proto_translation::to_wire(summary, &track);
    response.status = 200;
    return response.set_content(::mm::wire::body_text(::mm::wire::to_json(track)), kJsonType);
  }
  finish(take, summary);
  send_frames(take, chosen.shape(), response);
}

}  // namespace mm::service::rest
