// REST's POST /v1/join (server/rest/README.md "Joining clips"): clips a and b
// joined by a generated or crossfaded transition (Core::join_clips).
// The body is JSON ({"a": motion, "b": motion, "transition_seconds",
// "method", "decoder", "model"}, the proto's JoinClipsRequest), or
// multipart/form-data whose file parts "a" and "b" are BVH, glTF or FBX of
// the model's skeleton, read whole at their own rate and taken to 25 Hz for
// the model that answers, and whose plain parts are the JSON's other
// members. The reply is JSON (JoinClipsReply), or the joined motion as a
// file when Accept names application/x-bvh, model/gltf-binary or
// model/gltf+json, with the transition's frames in the headers
// X-Transition-First-Frame and X-Transition-Last-Frame.
//
// Thread safety: pure translation around the core's thread-safe calls.
#pragma once

#include <httplib.h>

#include <string>

#include "server/core/core.h"

namespace mm::service::rest {

// Answers one POST /v1/join whose body has been read: into `body`, or into
// `parts` for a multipart/form-data body. Throws ApiError for the caller to
// answer.
void answer_join(Core& core, const CallContext& context, const httplib::Request& request,
                 const std::string& body, const httplib::MultipartFormDataItems& parts, httplib::Response& response);

}  // namespace mm::service::rest
