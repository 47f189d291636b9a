// REST's take routes (server/rest/README.md "Takes"): POST /v1/takes:encode,
// /v1/takes:reconstruct, /v1/takes:denoise and /v1/tracks:decode. The body
// (motion text, BVH at its own Frame Time, or the track's JSON) and the query
// become one core call; the reply, gathered whole because its summary goes
// in the X-Take-* headers, is answered as the Accept header asks: JSON
// (default), BVH of the model's skeleton (application/x-bvh) or motion text
// (text/plain).
//
// Thread safety: pure translation around the core's thread-safe calls.
#pragma once

#include <string>

#include "server/core/core.h"
#include "server/rest/rest_routes.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace mm::service::rest {

// Answers one request of a take route (kEncodeTake, kReconstructTake,
// kDenoiseTake, kDecodeTrack) whose body has been read. Throws ApiError
// for the caller to answer.
void answer_take(Core& core, RouteId route, const CallContext& context, const httplib::Request& request,
                 const std::string& body, httplib::Response& response);

}  // namespace mm::service::rest
