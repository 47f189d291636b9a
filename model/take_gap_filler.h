// A take's gaps filled as its frames are answered: the take processor's
// keep_observed path (take_processor.h) hands each answered frame's input
// (NaN where missing) and the model's output here, and gets back the frames
// whose gaps are final, filled by fill_gap() (gap_interpolation.h).
//
// A gap is filled only once both its borders, and the frame beyond each
// (the border velocities of the cubic), have arrived, so frames are held
// from two frames before the earliest gap still open: what is held depends
// on the gaps' lengths and the batch, never on the take's. Where the
// detail's gain matches the recording's speed around a gap
// (GapFillOptions::speed_gain_range), its context (speed_context_seconds)
// on both sides is waited for and kept as well. Filling each held gap once
// all of it is held gives exactly what fill_gaps() gives on the whole take.
//
// Used by one thread at a time; torch-free.
#pragma once

#include <cstdint>

#include "format/motion_frames.h"
#include "model/gap_interpolation.h"

namespace mm {

class TakeGapFiller {
 public:
  TakeGapFiller(int columns, GapFillOptions options, double rate_hz);

  // `given`: the next input frames (NaN where missing); `decoded`: the
  // model's output for them (same count and columns). Appends to `out` the
  // frames now final: the given values where observed, filled where
  // missing, the root translation columns the decoded frames'.
  void push(const MotionFrames& given, const MotionFrames& decoded, MotionFrames& out);
  // The take has ended: appends every frame still held.
  void finish(MotionFrames& out);

  int64_t held_frames() const { return given_.frame_count(); }

 private:
  void hand_out(int64_t count, MotionFrames& out);

  GapFillOptions options_;
  double rate_hz_;
  int64_t context_;  // frames read beyond a gap's borders
  // Held frames: the last handed_ (at most context_) handed out already,
  // then those not yet handed out.
  MotionFrames given_, decoded_;
  int64_t handed_ = 0;
};

}  // namespace mm
