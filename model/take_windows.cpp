#include "model/take_windows.h"

#include <cmath>
#include <cstdio>

#include "format/input_error.h"

namespace mm {
namespace {

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", seconds);
  return text;
}

}  // namespace

TakeWindowing take_windowing(int window_frames, double hop_seconds) {
  if (window_frames < 1) throw InputError("window_frames", "expected at least 1, found " + std::to_string(window_frames));
  const double hop_frames = std::isfinite(hop_seconds) ? std::round(hop_seconds * kTakeModelRate) : -1.0;
  if (!(hop_frames >= 1 && hop_frames <= window_frames)) {
    throw InputError("hop_seconds", "expected " + seconds_text(1 / kTakeModelRate) + " to " +
                     seconds_text(window_frames / kTakeModelRate) +
                     " s (one frame at 25 Hz to one window: a longer hop would leave frames out), found " +
                     seconds_text(hop_seconds));
  }
  return {window_frames, static_cast<int>(hop_frames)};
}

int64_t minimum_take_frames(const TakeWindowing& windowing, double rate_hz) {
  // The 1e-9 matches resampled_frame_count's tolerance, so that a take of
  // exactly this many frames resamples to one whole window.
  const double span = (windowing.window_frames - 1) / kTakeModelRate * rate_hz;
  return static_cast<int64_t>(std::ceil(span - 1e-9)) + 1;
}

std::vector<int64_t> take_window_starts(int64_t frames, const TakeWindowing& windowing, double rate_hz) {
  const int64_t window = windowing.window_frames;
  if (frames < window) {
    // A duration is frames over rate: 150 frames at 25 Hz are a 6 s clip.
    char rate[32];
    std::snprintf(rate, sizeof rate, "%g", rate_hz);
    throw InputError("take", seconds_text(frames / kTakeModelRate) + " s (" + std::to_string(frames) +
                     " frames at 25 Hz) is shorter than one window of the model (" +
                     seconds_text(window / kTakeModelRate) + " s); expected at least " +
                     std::to_string(minimum_take_frames(windowing, rate_hz)) + " frames at " + rate + " Hz");
  }
  std::vector<int64_t> starts;
  int64_t start = 0;
  for (; start + window <= frames; start += windowing.hop_frames) starts.push_back(start);
  if (starts.back() + window < frames) starts.push_back(frames - window);
  return starts;
}

}  // namespace mm
