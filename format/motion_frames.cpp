#include "format/motion_frames.h"

namespace mm {

int64_t MotionFrames::frame_count() const {
  return columns > 0 ? static_cast<int64_t>(values.size()) / columns : 0;
}

const float* MotionFrames::frame(int64_t i) const { return values.data() + i * columns; }

float* MotionFrames::frame(int64_t i) { return values.data() + i * columns; }

}  // namespace mm
