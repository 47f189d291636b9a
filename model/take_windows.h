// Where a take is cut into the windows the model reads: clips of the model's
// length (150 frames, 6 s at 25 Hz) every `hop` frames from the take's start,
// and the last window aligned to the take's end, so that every frame is in
// at least one window and no window reaches past the take.
//
// Torch-free and reentrant. Bad arguments throw InputError naming the field.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace mm {

// The model's rate, at which takes are windowed.
constexpr double kTakeModelRate = 25.0;
constexpr double kDefaultHopSeconds = 3.0;

struct TakeWindowing {
  int window_frames = 150;  // the model's clip, frames at 25 Hz
  int hop_frames = 75;      // between window starts, frames at 25 Hz (3 s)
};

// The windowing of a model whose clip is `window_frames` long at a hop of
// `hop_seconds`, rounded to whole 25 Hz frames. Throws InputError
// "hop_seconds: expected 0.04 to <window> s ..., found <value>" unless the hop
// is one frame to one window long (a longer hop would leave frames out).
TakeWindowing take_windowing(int window_frames, double hop_seconds = kDefaultHopSeconds);

// Starts (25 Hz frames) of the windows of a take of `frames` frames at 25 Hz:
// 0, hop, 2 hop, ... while the window fits, then frames - window when the
// last one did not end at the take's end. Throws InputError "take: ..." when
// the take is shorter than one window, naming its length and the minimum in
// seconds and in frames at `rate_hz` (the caller's rate, for the message).
// Takes are not padded: a padded window would show the model a motion that
// stands still, which it reconstructs worse than any real one.
std::vector<int64_t> take_window_starts(int64_t frames, const TakeWindowing& windowing, double rate_hz = kTakeModelRate);

// The shortest take at `rate_hz`, in its own frames: one window's duration,
// (window - 1) / 25 s, rounded up, plus one frame.
int64_t minimum_take_frames(const TakeWindowing& windowing, double rate_hz);

}  // namespace mm
