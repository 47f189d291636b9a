#include "format/h36m_bvh.h"

#include "format/skeleton.h"

namespace mm {

BvhFile h36m_motion_to_bvh(const MotionFrames& motion, double rate_hz, const H36mBvhExportOptions& options) {
  const Skeleton h36m = Skeleton::h36m();
  return skeleton_motion_to_bvh(
      h36m, default_bvh_layout(h36m, options.rotation_order, options.position_channels_on_every_joint), motion,
      rate_hz);
}

std::string h36m_motion_to_bvh_text(const MotionFrames& motion, double rate_hz, const H36mBvhExportOptions& options) {
  return write_bvh_text(h36m_motion_to_bvh(motion, rate_hz, options));
}

MotionFrames h36m_motion_from_bvh(const BvhFile& file, const std::string& source_name) {
  return skeleton_motion_from_bvh(Skeleton::h36m(), file, source_name);
}

MotionFrames h36m_motion_from_bvh_text(const std::string& text, const std::string& source_name) {
  return h36m_motion_from_bvh(parse_bvh_text(text, source_name), source_name);
}

}  // namespace mm
