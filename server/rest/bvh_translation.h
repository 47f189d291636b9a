// BVH <-> the core's motions for the REST frontend: a request body of
// Content-Type application/x-bvh on /v1/encode and /v1/denoise is one motion
// (a BVH of the model's skeleton, format/skeleton_bvh.h: any rotation order
// and frame time, taken to 25 Hz by nearest frames), and a reply with one
// motion is written as BVH of the model's skeleton in its own channel layout
// and unit (H3.6M's: offsets in mm, Z Y X rotations), frame time 0.04 s, when
// the request's Accept header names application/x-bvh.
//
// Torch-free (mm_format). Thread safety: pure functions.
#pragma once

#include <string>

#include "api/api_types.h"
#include "core/motion_conversion.h"

namespace mm::service::rest {

constexpr const char* kBvhType = "application/x-bvh";

// Whether a Content-Type or Accept header value names application/x-bvh
// (parameters and case ignored).
bool names_bvh(const std::string& header_value);

// The motion in a BVH body, in the layout of the model of `shape` at 25 Hz.
// Throws ApiError INVALID_ARGUMENT with field "" and the parser's message
// ("request body:<line>: ...", or what differs from the model's skeleton),
// and for a body that does not make the model's clip at 25 Hz: a longer one
// at its "Frame Time:" line, before its frames are read.
Motion motion_from_bvh_body(const std::string& body, const ModelShape& shape);

// The single motion of `reply` as BVH text of the skeleton of `shape` (the
// model that answered). Throws ApiError INVALID_ARGUMENT when the reply holds
// another number of motions (the frontend answers 406 Not Acceptable for it),
// INTERNAL for a motion not in the skeleton's layout.
std::string motions_reply_to_bvh(const MotionsReply& reply, const ModelShape& shape);

}  // namespace mm::service::rest
