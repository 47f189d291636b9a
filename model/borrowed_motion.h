// A gap's movement borrowed from the take itself: for each run of frames
// where joints are missing, the stretch of the same take, observed in every
// joint, whose frames around it (and whose joints that are observed inside
// the gap) are most like the gap's, stretched in time to the gap's length.
//
// Why: people repeat themselves within a take (a walk's steps, a gesture,
// a weight shift), and a recorded stretch moves as the recording does. Laid
// over the cubic across the gap as the manifold's detail is
// (gap_interpolation.h: its movement relative to its own path across the
// gap), it meets the observed borders exactly and keeps the take's own
// speed, where the manifold's fill of someone it never saw drifts from the
// recording and an interpolation stands still. On a motion that does not
// repeat, the nearest stretch is another motion: a stretch is taken only
// where it is like enough (BorrowOptions::max_cost). Only what lies within
// BorrowOptions::search_seconds before a gap and lookahead_seconds after it
// is searched, so a streamed take borrows as the whole take does, holding a
// bounded past and waiting a bounded time.
//
// Motions are MotionFrames in the exponential-map layout (gap_interpolation.h).
// Torch-free and reentrant: pure functions over value types.
#pragma once

#include <cstdint>
#include <vector>

#include "format/motion_frames.h"
#include "format/skeleton.h"
#include "model/gap_interpolation.h"

namespace mm {

// The groups of joints the take path borrows for apart
// (BorrowOptions::parts): the legs, with the joints from the root to the
// pelvis (the first joint with more than one child), and the upper body (the
// pelvis's branch holding the most joints). Empty for a skeleton that does
// not branch so.
std::vector<std::vector<int>> body_parts(const Skeleton& skeleton);

// Where a missing span's movement was borrowed from.
struct BorrowedSpan {
  FrameSpan span;            // the missing frames
  bool found = false;        // a stretch was searched and found (whatever its cost)
  int64_t source_left = 0;   // the source frame answering the span's left border (first - 1)
  int64_t source_frames = 0; // the source's frames between its borders, answering last + 1 - (first - 1)
  // How unlike the gap's surroundings the source's are: the mean over the
  // compared joint values of 1 - cos^2(angle / 2) (0 alike, 1 opposite;
  // about (angle / 2)^2 for small angles).
  double cost = 0;
  bool used = false;  // found, and cheap enough to be laid over the span
  int part = -1;      // the index in BorrowOptions::parts searched for (-1: the whole body)
};

// A motion of `observed`'s shape whose frames first - 2 .. last + 2 of each
// missing span (find_missing_spans) whose best source costs at most
// options.max_cost hold that source, stretched to the span (the borders and
// their neighbours included, as fill_gaps reads them); every other value is
// the observed one (so missing in the other spans: fill_gaps lays no
// detail there). A span whose whole-body source costs more than that, with
// options.parts, holds in each part's joints the part's own best source
// where it costs at most options.part_max_cost. Spans ending before frame
// `needed_from` are not searched. `spans` (may be null) receives each
// searched span's best source of the whole body, then where the parts were
// searched each part's, in order.
MotionFrames borrow_take_motion(const MotionFrames& observed, double rate_hz, const BorrowOptions& options,
                                int64_t needed_from = 0, std::vector<BorrowedSpan>* spans = nullptr);

}  // namespace mm
