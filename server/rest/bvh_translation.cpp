#include "server/rest/bvh_translation.h"

#include <cctype>
#include <cstdio>

#include "format/bvh_file.h"
#include "format/input_error.h"
#include "format/skeleton_bvh.h"

namespace mm::service::rest {

bool names_bvh(const std::string& header_value) {
  std::string lower = header_value;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find(kBvhType) != std::string::npos;
}

bool names_animation(const std::string& header_value, AnimationFormat* format) {
  std::string lower = header_value;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (AnimationFormat f : {AnimationFormat::kBvh, AnimationFormat::kGlb, AnimationFormat::kGltf, AnimationFormat::kFbx}) {
    if (lower.find(animation_format_media_type(f)) != std::string::npos) {
      *format = f;
      return true;
    }
  }
  return false;
}

AnimationFormat animation_body_format(const std::string& body, AnimationFormat format, const std::string& source) {
  if (format == AnimationFormat::kFbx) {
    // application/octet-stream says nothing of the bytes: FBX's or glb's
    // first bytes decide.
    AnimationFormat sniffed;
    if (!sniff_animation_format(body.data(), body.size(), &sniffed) ||
        (sniffed != AnimationFormat::kFbx && sniffed != AnimationFormat::kGlb)) {
      throw InputError(source + ": Content-Type application/octet-stream is read as FBX or glTF binary, and the "
                       "body begins with neither \"Kaydara FBX Binary\" nor \"glTF\"");
    }
    format = sniffed;
  }
  return format;
}

BvhFile animation_body_as_bvh(const std::string& body, AnimationFormat format, const Skeleton& skeleton,
                              const std::string& source, const BvhFrameLimit& limit) {
  return parse_animation_file(body, animation_body_format(body, format, source), source,
                              bvh_layout_of(skeleton).millimetres_per_unit, limit);
}

namespace {

// A motion read from an animation body: at the rate the BVH import takes
// every file to, in the model's layout.
Motion imported_motion(MotionFrames frames, const ModelShape& shape) {
  Motion motion;
  motion.frames = static_cast<int>(frames.frame_count());
  motion.columns = frames.columns;
  motion.frame_rate = kBvhImportRate;
  motion.layout = shape.layout;
  motion.values = std::move(frames.values);
  return motion;
}

}  // namespace

Motion motion_from_bvh_body(const std::string& body, const ModelShape& shape, AnimationFormat format) {
  // The body must make the model's clip at 25 Hz: a longer one is refused at
  // its "Frame Time:" line, before its frames are read, and a shorter one
  // before it is resampled.
  char duration[32];
  std::snprintf(duration, sizeof duration, "%g", shape.frames / kBvhImportRate);  // 150 frames: 6 s
  BvhFrameLimit clip;
  clip.frames = shape.frames;
  clip.name = "the model's clip (" + std::string(duration) + " s at 25 Hz)";
  MotionFrames frames;
  try {
    const BvhFile file = animation_body_as_bvh(body, format, shape.skeleton, "request body", clip);
    match_bvh_to_skeleton(shape.skeleton, file, "request body");  // another hierarchy says so first
    const int64_t imported = bvh_imported_frame_count(file.frame_count(), file.frame_time_s);
    if (imported < shape.frames) {
      char frame_time[32];
      std::snprintf(frame_time, sizeof frame_time, "%g", file.frame_time_s);
      throw InputError("request body: " + std::to_string(file.frame_count()) + " frames of " + frame_time +
                       " s make " + std::to_string(imported) +
                       " frames at 25 Hz, expected the " + std::to_string(shape.frames) + " of " + clip.name);
    }
    frames = skeleton_motion_from_bvh(shape.skeleton, file, "request body", clip);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, "", error.what());
  }
  return imported_motion(std::move(frames), shape);
}

Motion clip_from_animation_body(const std::string& body, const ModelShape& shape, AnimationFormat format,
                                const std::string& field) {
  MotionFrames frames;
  try {
    const BvhFile file = animation_body_as_bvh(body, format, shape.skeleton, field);
    match_bvh_to_skeleton(shape.skeleton, file, field);
    frames = skeleton_motion_from_bvh(shape.skeleton, file, field);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, field, error.what());
  }
  return imported_motion(std::move(frames), shape);
}

std::string motions_reply_to_bvh(const MotionsReply& reply, const ModelShape& shape, AnimationFormat format) {
  if (reply.motions.size() != 1) {
    throw ApiError(ErrorCode::kInvalidArgument, "",
                   std::string("Accept: ") + animation_format_media_type(format) + " holds one motion and this reply has " +
                       std::to_string(reply.motions.size()) + "; ask for application/json");
  }
  const Motion& motion = reply.motions.front();
  MotionFrames frames;
  frames.columns = motion.columns;
  frames.values = motion.values;
  try {
    return write_animation_file(skeleton_motion_to_bvh(shape.skeleton, bvh_layout_of(shape.skeleton), frames,
                                                       motion.frame_rate > 0 ? motion.frame_rate : kBvhImportRate),
                                format, bvh_layout_of(shape.skeleton).millimetres_per_unit);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInternal, "", std::string("the reply cannot be written as BVH: ") + error.what());
  }
}

}  // namespace mm::service::rest
