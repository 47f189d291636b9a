#include "format/motion_resampling.h"

#include <cmath>
#include <sstream>

#include "format/expmap_slerp.h"
#include "format/input_error.h"

namespace mm {
namespace {

// Tolerance, in input frames, for an output time that falls on an input
// frame but is computed a rounding error short of it (k x 4.8 at 120 Hz),
// or from rates a file gave to a few significant digits: a millionth of a
// frame, which no take is long enough to accumulate from rates rounded to
// a millionth of a hertz (bvh_frame_rate).
constexpr double kOnFrame = 1e-6;

std::string number_text(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

}  // namespace

void check_take_rate(double rate_hz, const std::string& field) {
  if (!(rate_hz >= kMinTakeRate && rate_hz <= kMaxTakeRate)) {
    throw InputError(field, "expected a frame rate of " + number_text(kMinTakeRate) + " to " +
                     number_text(kMaxTakeRate) + " Hz, found " + number_text(rate_hz));
  }
}

int64_t resampled_frame_count(int64_t frames, double from_hz, double to_hz) {
  if (frames <= 0) return 0;
  return static_cast<int64_t>(std::floor(static_cast<double>(frames - 1) * to_hz / from_hz + kOnFrame)) + 1;
}

MotionResampler::MotionResampler(int columns, double from_hz, double to_hz)
    : columns_(columns), from_hz_(from_hz), to_hz_(to_hz) {
  check_take_rate(from_hz, "from_hz");
  check_take_rate(to_hz, "to_hz");
  if (columns < 3 || (columns - 3) % 3 != 0) {
    throw InputError("columns", "expected 3 root values and 3 per joint, found " + std::to_string(columns));
  }
}

void MotionResampler::push(const float* values, int64_t frames, MotionFrames& out) {
  if (finished_) throw InputError("MotionResampler::push after finish");
  out.columns = columns_;
  const int joints = (columns_ - 3) / 3;
  for (int64_t n = 0; n < frames; ++n) {
    const float* frame = values + n * columns_;
    const int64_t j = input_frames_++;
    double root[3];
    for (int c = 0; c < 3; ++c) root[c] = (j == 0 ? 0.0 : previous_root_[c]) + frame[c];
    // Output frames whose time lies in (t_{j-1}, t_j]: x is the time in
    // input frames, between j - 1 and j.
    for (;;) {
      const double x = static_cast<double>(output_frames_) * from_hz_ / to_hz_;
      if (x > static_cast<double>(j) + kOnFrame) break;
      const double fraction = x - static_cast<double>(j - 1);  // of the way from frame j - 1 to j
      const bool on_frame = j == 0 || fraction >= 1 - kOnFrame;
      const size_t at = out.values.size();
      out.values.resize(at + columns_);
      float* target = out.values.data() + at;
      double position[3];
      for (int c = 0; c < 3; ++c) {
        position[c] = on_frame ? root[c] : previous_root_[c] + fraction * (root[c] - previous_root_[c]);
        target[c] = static_cast<float>(output_frames_ == 0 ? frame[c] : position[c] - output_root_[c]);
        output_root_[c] = position[c];
      }
      for (int joint = 0; joint < joints; ++joint) {
        const int c = 3 + 3 * joint;
        if (on_frame) {
          for (int i = 0; i < 3; ++i) target[c + i] = frame[c + i];
        } else {
          slerp_expmap(previous_.data() + c, frame + c, fraction, target + c);
        }
      }
      ++output_frames_;
    }
    previous_.assign(frame, frame + columns_);
    for (int c = 0; c < 3; ++c) previous_root_[c] = root[c];
  }
}

int64_t MotionResampler::finish(MotionFrames& out, int64_t total_output_frames) {
  finished_ = true;
  out.columns = columns_;
  while (output_frames_ > 0 && output_frames_ < total_output_frames) {
    const size_t at = out.values.size();
    if (at < static_cast<size_t>(columns_)) {
      throw InputError("MotionResampler::finish: the output so far is not in `out`, cannot hold its last frame");
    }
    out.values.resize(at + columns_);
    float* target = out.values.data() + at;
    std::copy(target - columns_, target, target);
    for (int c = 0; c < 3; ++c) target[c] = 0.0f;
    ++output_frames_;
  }
  return output_frames_;
}

MotionFrames resample_motion(const MotionFrames& motion, double from_hz, double to_hz, int64_t total_output_frames) {
  MotionResampler resampler(motion.columns, from_hz, to_hz);
  MotionFrames out;
  out.columns = motion.columns;
  out.values.reserve(static_cast<size_t>(resampled_frame_count(motion.frame_count(), from_hz, to_hz)) *
                     motion.columns);
  resampler.push(motion.values.data(), motion.frame_count(), out);
  resampler.finish(out, total_output_frames);
  return out;
}

}  // namespace mm
