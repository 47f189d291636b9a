// BVH <-> the core's motions for the REST frontend: a request body of
// Content-Type application/x-bvh on /v1/encode and /v1/denoise is one motion
// (a BVH of the model's skeleton, format/skeleton_bvh.h: any rotation order
// and frame time, taken to 25 Hz by nearest frames), and a reply with one
// motion is written as BVH of the model's skeleton in its own channel layout
// and unit (H3.6M's: offsets in mm, Z Y X rotations), frame time 0.04 s, when
// the request's Accept header names application/x-bvh.
//
// glTF (model/gltf-binary, model/gltf+json) and FBX (application/octet-stream,
// checked by its first bytes; read only) go wherever BVH does, in the rig's
// unit (format/animation_file.h).
//
// Torch-free (mm_format). Thread safety: pure functions.
#pragma once

#include <string>

#include "format/animation_file.h"
#include "format/bvh_file.h"
#include "format/skeleton.h"
#include "server/api/api_types.h"
#include "server/core/motion_conversion.h"

namespace mm::service::rest {

constexpr const char* kBvhType = "application/x-bvh";

// Whether a Content-Type or Accept header value names application/x-bvh
// (parameters and case ignored).
bool names_bvh(const std::string& header_value);

// The animation format a Content-Type or Accept value names:
// application/x-bvh, model/gltf-binary, model/gltf+json or
// application/octet-stream (FBX), in that order (parameters and case
// ignored); false for none of them (JSON, motion text).
bool names_animation(const std::string& header_value, AnimationFormat* format);

// The motion in a BVH body, in the layout of the model of `shape` at 25 Hz.
// Throws ApiError INVALID_ARGUMENT with field "" and the parser's message
// ("request body:<line>: ...", or what differs from the model's skeleton),
// and for a body that does not make the model's clip at 25 Hz: a longer one
// at its "Frame Time:" line, before its frames are read.
Motion motion_from_bvh_body(const std::string& body, const ModelShape& shape,
                            AnimationFormat format = AnimationFormat::kBvh);

// A clip of any length in an animation body (JoinClips' a and b; a part of
// a multipart body), in the layout of the model of `shape` at 25 Hz, all of
// its frames (bounded as a take's are when it is parsed: the core then
// bounds a clip by --max-take-seconds). Throws ApiError INVALID_ARGUMENT
// naming `field` ("a", "b") with the parser's message.
Motion clip_from_animation_body(const std::string& body, const ModelShape& shape, AnimationFormat format,
                                const std::string& field);

// The single motion of `reply` as BVH text of the skeleton of `shape` (the
// model that answered). Throws ApiError INVALID_ARGUMENT when the reply holds
// another number of motions (the frontend answers 406 Not Acceptable for it),
// INTERNAL for a motion not in the skeleton's layout.
std::string motions_reply_to_bvh(const MotionsReply& reply, const ModelShape& shape,
                                 AnimationFormat format = AnimationFormat::kBvh);

// The format of a body sent as `named`: `named`, except that a body of
// application/octet-stream must be FBX or glTF binary by its first bytes.
// Throws InputError naming `source` for neither.
AnimationFormat animation_body_format(const std::string& body, AnimationFormat named, const std::string& source);

// An animation body of `format` as a BVH of `skeleton`'s rig, `source` naming
// it in messages: BVH parsed, glTF and FBX read in the rig's unit. A body of
// application/octet-stream must be FBX or glTF binary by its first bytes.
// Throws InputError.
BvhFile animation_body_as_bvh(const std::string& body, AnimationFormat format, const Skeleton& skeleton,
                              const std::string& source, const BvhFrameLimit& limit = {});

}  // namespace mm::service::rest
