// MotionFrames: a motion as the library passes it around, a matrix of
// frames by columns, whatever file it came from or goes to.
//
// For H3.6M a frame has 99 values: [0:3] root translation (mm, per-frame
// change), then 32 joints x 3 exponential-map values in radians, joint j at
// columns 3+3j..5+3j. Other column counts are accepted for other skeletons.
#pragma once

#include <cstdint>
#include <vector>

namespace mm {

constexpr int kH36mColumns = 99;
constexpr double kH36mFrameRate = 50.0;  // frames per second of the text files
constexpr int kRootTranslationValues = 3;  // the first values of a frame

// A sequence of frames, row-major: values[i * columns + c] is column c of
// frame i. Plain value type; not synchronised.
struct MotionFrames {
  int columns = kH36mColumns;
  std::vector<float> values;

  // Number of frames: values.size() / columns (0 when columns <= 0).
  int64_t frame_count() const;
  // Pointer to the `columns` values of frame i. No bounds check: i must be in
  // [0, frame_count()). Valid until `values` is resized.
  const float* frame(int64_t i) const;
  float* frame(int64_t i);
};

}  // namespace mm
