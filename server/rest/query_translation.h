// The query string of a route -> the core's plain types, for the routes
// that take their request there (GET /v1/clips/window and /v1/clips/motion: a read names a file
// and a frame, and a GET can be bookmarked, cached and linked from the page;
// POST /v1/clips:upload, whose body is the file itself; DELETE /v1/clips). Strict as the JSON bodies are: an unknown parameter, one given
// twice, or a value that is not of its type is INVALID_ARGUMENT naming the
// parameter. Values in range are the core's to check.
//
// Thread safety: pure functions; call from any thread.
#pragma once

#include <map>
#include <string>

#include "server/api/api_types.h"
#include "server/core/take_session.h"

namespace mm::service::rest {

// The decoded query parameters, as httplib gives them.
using QueryParameters = std::multimap<std::string, std::string>;

// ?path=<relative path>&start=<integer, default 0>&model=<name, default the active model>
ReadClipRequest read_clip_request_from_query(const QueryParameters& parameters);

// GET /v1/clips/motion: ?path=<relative path>&model=<name, default the
// active model>, the whole file (ReadClipRequest.whole); no start.
ReadClipRequest read_clip_motion_request_from_query(const QueryParameters& parameters);

// ?path=<relative path of the new file>, and the body as its content.
UploadClipRequest upload_clip_request_from_query(const QueryParameters& parameters, std::string content);

// ?path=<relative path of an uploaded file> (DELETE /v1/clips): the path.
std::string delete_clip_path_from_query(const QueryParameters& parameters);

// POST /v1/takes:encode|reconstruct|denoise: ?model, frame_rate (motion
// text only; default 50), hop_seconds, blend, decoder, at_model_rate
// (true|false), path (a data-root file as the take), and for denoise
// (`denoise`) zeros_are_missing, means_are_missing, iterations, keep_observed,
// gap_fill (borrowed, fitted, matched, cubic, slerp, hold or manifold; with
// keep_observed only).
// frame_rate with a BVH body (`bvh_body`) is refused: its rate is its Frame Time.
TakeRequest take_request_from_query(const QueryParameters& parameters, bool denoise, bool bvh_body);

}  // namespace mm::service::rest
