#include "rest/bvh_translation.h"

#include <cctype>
#include <cstdio>

#include "format/bvh_file.h"
#include "format/skeleton_bvh.h"
#include "format/input_error.h"

namespace mm::service::rest {

bool names_bvh(const std::string& header_value) {
  std::string lower = header_value;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find(kBvhType) != std::string::npos;
}

Motion motion_from_bvh_body(const std::string& body, const ModelShape& shape) {
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
    const BvhFile file = parse_bvh_text(body, "request body", clip);
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
  Motion motion;
  motion.frames = static_cast<int>(frames.frame_count());
  motion.columns = frames.columns;
  motion.frame_rate = kBvhImportRate;
  motion.layout = shape.layout;
  motion.values = std::move(frames.values);
  return motion;
}

std::string motions_reply_to_bvh(const MotionsReply& reply, const ModelShape& shape) {
  if (reply.motions.size() != 1) {
    throw ApiError(ErrorCode::kInvalidArgument, "",
                   "Accept: application/x-bvh holds one motion and this reply has " +
                       std::to_string(reply.motions.size()) + "; ask for application/json");
  }
  const Motion& motion = reply.motions.front();
  MotionFrames frames;
  frames.columns = motion.columns;
  frames.values = motion.values;
  try {
    return write_bvh_text(skeleton_motion_to_bvh(shape.skeleton, bvh_layout_of(shape.skeleton), frames,
                                                 motion.frame_rate > 0 ? motion.frame_rate : kBvhImportRate));
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInternal, "", std::string("the reply cannot be written as BVH: ") + error.what());
  }
}

}  // namespace mm::service::rest
