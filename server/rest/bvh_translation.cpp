#include "rest/bvh_translation.h"

#include <cctype>

#include "format/h36m_bvh.h"
#include "format/input_error.h"

namespace mm::service::rest {

bool names_bvh(const std::string& header_value) {
  std::string lower = header_value;
  for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return lower.find(kBvhType) != std::string::npos;
}

Motion motion_from_bvh_body(const std::string& body) {
  MotionFrames frames;
  try {
    frames = h36m_motion_from_bvh_text(body, "request body");
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInvalidArgument, "", error.what());
  }
  Motion motion;
  motion.frames = static_cast<int>(frames.frame_count());
  motion.columns = frames.columns;
  motion.frame_rate = kH36mBvhImportRate;
  motion.layout = kH36mLayout;
  motion.values = std::move(frames.values);
  return motion;
}

std::string motions_reply_to_bvh(const MotionsReply& reply) {
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
    return h36m_motion_to_bvh_text(frames, motion.frame_rate > 0 ? motion.frame_rate : kH36mBvhImportRate);
  } catch (const InputError& error) {
    throw ApiError(ErrorCode::kInternal, "", std::string("the reply cannot be written as BVH: ") + error.what());
  }
}

}  // namespace mm::service::rest
