// A take's gaps filled as its frames are answered: the take processor's
// keep_observed path (take_processor.h) hands each answered frame's input
// (NaN where missing) and the model's output here, and gets back the frames
// whose gaps are final, filled by fill_gap() (gap_interpolation.h).
//
// A gap is filled only once both its borders, and the frame beyond each
// (the border velocities of the cubic), have arrived, so frames are held
// from two frames before the earliest gap still open: what is held depends
// on the gaps' lengths and the batch, never on the take's. A gap is bridged
// over at most its last GapFillOptions::max_bridged_seconds: its frames
// before those are filled from its left border alone as they become known
// to be before them (written into the held frames as if observed), so
// nothing is held longer than that and a few frames after it arrived,
// however long a joint stays missing. Where the
// detail's gain matches the recording's speed around a gap
// (GapFillOptions::speed_gain_range), its context (speed_context_seconds)
// on both sides is waited for and kept as well; for the borrowed fill the
// frames it may borrow from after a gap are waited for
// (BorrowOptions::lookahead_seconds, 10 s) and those before it kept
// (search_seconds, 60 s). Filling each held gap once
// all of it is held gives exactly what fill_gaps() gives on the whole take.
//
// Used by one thread at a time; torch-free.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

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
  // Fills the heads of the long gaps held (the frames known to lie before
  // their bridge; all of a gap still open when the take has `ended`).
  void fill_long_gap_heads(bool ended);
  void hand_out(int64_t count, MotionFrames& out);
  bool borrows() const { return options_.method == GapMethod::kBorrowed; }

  // A long gap whose head is being filled: `next` the take's frame after
  // the last one filled.
  struct OpenHead {
    LongGapHead head;
    int64_t next = 0;
  };

  GapFillOptions options_;
  double rate_hz_;
  int64_t context_;  // frames read beyond a gap's borders
  int64_t history_;  // frames kept before the first not handed out (at least context_)
  int64_t bridge_;   // max_bridged_frames
  // Held frames: the last handed_ (at most context_) handed out already,
  // then those not yet handed out; the first is the take's frame first_.
  // A long gap's head frames are filled in given_.
  MotionFrames given_, decoded_;
  MotionFrames as_given_;  // the borrowed fill's: given_ before the long gaps' heads were written
  int64_t handed_ = 0, first_ = 0;
  std::vector<bool> most_missing_;  // held frames with most joints missing, as given
  std::map<int, OpenHead> heads_;   // by joint
};

}  // namespace mm
