// Motions of the exponential-map layout (motion_text.h, skeleton_bvh.h:
// columns 0..2 the root's change of position since the previous frame in mm,
// then one exponential map per joint) brought from one frame rate to
// another, frame by frame as they arrive, so that a take of any length is
// resampled holding two of its frames.
//
// Output frame k lies at time k / to_hz; between the input frames i and i + 1
// around it (fraction f of the way), every joint is slerp_expmap(i, i + 1, f)
// (rotations on the sphere), and the root position (the running sum of the
// changes) is interpolated linearly and written back as the change since the
// previous output frame (output frame 0 keeps input frame 0's change). The
// output covers the input's duration: frames from time 0 to the last input
// frame's time.
//
// Thread safety: a MotionResampler is used by one thread at a time; the free
// functions are reentrant. Bad arguments throw InputError naming them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

// Frame rates a take may have.
constexpr double kMinTakeRate = 10.0;
constexpr double kMaxTakeRate = 1000.0;

// Throws InputError "<field>: expected a frame rate of 10 to 1000 Hz, found
// <value>" for a rate outside that range, zero, negative, NaN or infinite.
void check_take_rate(double rate_hz, const std::string& field);

// Frames at to_hz covering `frames` frames at from_hz: one at every 1 / to_hz
// from the first frame's time to the last's, floor((frames - 1) x to / from)
// + 1 (with a tolerance of 1e-6 frame for rates whose ratio is not exact in
// binary); 0 for no frames.
int64_t resampled_frame_count(int64_t frames, double from_hz, double to_hz);

class MotionResampler {
 public:
  // Frames of `columns` values (3 + 3 x joints) from from_hz to to_hz (each
  // checked by check_take_rate; the fields are named "from_hz"/"to_hz").
  MotionResampler(int columns, double from_hz, double to_hz);

  // Takes `frames` more input frames (columns values each, row-major) and
  // appends to `out` (of the same columns) every output frame they complete.
  void push(const float* values, int64_t frames, MotionFrames& out);
  // Ends the input. Every output frame up to the last input frame's time
  // has been appended by push(); with total_output_frames larger than the
  // output so far, frames are appended up to that count, holding the last
  // output frame's rotations with no root change (the at most one frame
  // time of the input that the grid of the output rate does not reach).
  // Returns the output frame count.
  int64_t finish(MotionFrames& out, int64_t total_output_frames = -1);

  int64_t input_frames() const { return input_frames_; }
  int64_t output_frames() const { return output_frames_; }

 private:
  int columns_;
  double from_hz_, to_hz_;
  int64_t input_frames_ = 0, output_frames_ = 0;
  // The latest input frame, with its root position (the sum of the changes
  // so far), and the root position of the latest output frame.
  std::vector<float> previous_;
  double previous_root_[3] = {0, 0, 0};
  double output_root_[3] = {0, 0, 0};
  bool finished_ = false;
};

// The whole motion at once: MotionResampler over all of it. Same rate: a copy.
MotionFrames resample_motion(const MotionFrames& motion, double from_hz, double to_hz,
                             int64_t total_output_frames = -1);

}  // namespace mm
