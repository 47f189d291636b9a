#include "model/take_gap_filler.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace mm {

TakeGapFiller::TakeGapFiller(int columns, GapFillOptions options, double rate_hz)
    : options_(options),
      rate_hz_(rate_hz),
      // The speed-matched gain reads the observed frames within its context
      // of a gap; without it a gap reads one frame beyond each border.
      context_(options.speed_gain_range[0] == 1.0 && options.speed_gain_range[1] == 1.0
                   ? 1
                   : std::max<int64_t>(1, std::lround(options.speed_context_seconds * rate_hz))),
      // The borrowed fill searches this far before a span (at most
      // max_span_seconds long, before the first frame not handed out), and
      // waits for its context and lookahead after it (below).
      history_(options.method == GapMethod::kBorrowed
                   ? std::max(context_, std::lround((options.borrow.search_seconds + options.borrow.max_span_seconds +
                                                     options.borrow.context_seconds) * rate_hz) + 4)
                   : context_),
      bridge_(max_bridged_frames(options, rate_hz)) {
  if (options.method == GapMethod::kBorrowed) {
    context_ = std::max({context_, std::lround(options.borrow.context_seconds * rate_hz) + 1,
                         std::lround(options.borrow.lookahead_seconds * rate_hz) + 1});
  }
  given_.columns = decoded_.columns = as_given_.columns = columns;
}

void TakeGapFiller::push(const MotionFrames& given, const MotionFrames& decoded, MotionFrames& out) {
  given_.values.insert(given_.values.end(), given.values.begin(), given.values.end());
  if (borrows()) as_given_.values.insert(as_given_.values.end(), given.values.begin(), given.values.end());
  decoded_.values.insert(decoded_.values.end(), decoded.values.begin(), decoded.values.end());
  for (int64_t f = 0; f < given.frame_count(); ++f) most_missing_.push_back(most_joints_missing(given, f));
  fill_long_gap_heads(false);
  const int64_t held = given_.frame_count();
  // Hand out the frames before the first gap that is not final: one whose
  // right border or the `context_` frames after it have not arrived (the
  // cubic needs the first, the speed-matched gain all), keeping the frame
  // before its left border for the same reason (and the context_ frames
  // before it, kept after they are handed out). A final gap is handed out
  // whole or not at all; so is a span of gaps that touch or overlap (each
  // moves the end before the one it reaches into), which is what the
  // borrowed fill searches for as a whole: it is final once its last gap
  // and the lookahead after it have arrived.
  const auto gaps = find_joint_gaps(given_);
  int64_t end = held;
  for (const JointGap& gap : gaps) {
    if (gap.last + 1 + context_ >= held) end = std::max(handed_, std::min(end, gap.first - 2));
  }
  for (bool moved = true; moved;) {
    moved = false;
    for (const JointGap& gap : gaps) {
      const int64_t before = std::max(handed_, gap.first - 2);
      if (end > before && end <= gap.last) {
        end = before;
        moved = true;
      }
    }
  }
  hand_out(end - handed_, out);
}

void TakeGapFiller::finish(MotionFrames& out) {
  fill_long_gap_heads(true);
  hand_out(given_.frame_count() - handed_, out);
}

void TakeGapFiller::fill_long_gap_heads(bool ended) {
  const int64_t held = given_.frame_count();
  for (const JointGap& gap : find_joint_gaps(given_)) {
    // Open: its right border has not arrived, or the take ended in it.
    const bool open = gap.last == held - 1;
    auto it = heads_.find(gap.joint);
    if (it == heads_.end() || it->second.next != first_ + gap.first) {
      if (gap.last - gap.first + 1 <= bridge_) continue;
      // A gap that has just become long. Its left border is held (frames
      // are held from two before any gap not yet final) unless it is the
      // take's first frame.
      it = heads_.insert_or_assign(gap.joint, OpenHead{long_gap_head(given_, &decoded_, gap, options_,
                                                                    most_missing_[static_cast<size_t>(gap.first)]),
                                                       0})
               .first;
    }
    // As fill_gaps(): the frames before the last bridge_, or all of a gap
    // that runs to the take's end.
    const int64_t head_last = open ? (ended ? gap.last : held - 1 - bridge_) : gap.last - bridge_;
    for (int64_t f = gap.first; f <= head_last; ++f) fill_long_gap_head_frame(it->second.head, &decoded_, f, options_, given_);
    it->second.next = first_ + std::max(gap.first, head_last + 1);
    if (!open || ended) heads_.erase(it);
  }
}

void TakeGapFiller::hand_out(int64_t count, MotionFrames& out) {
  if (count <= 0) return;
  // Every gap held is filled again from the held frames: a gap's fill reads
  // only its own borders and the frame beyond each, which stay held until
  // it is handed out.
  MotionFrames filled = fill_gaps(given_, &decoded_, options_, rate_hz_, handed_, borrows() ? &as_given_ : nullptr);
  const int columns = given_.columns;
  for (int64_t f = handed_; f < handed_ + count; ++f) {
    std::memcpy(filled.frame(f), decoded_.frame(f), kRootTranslationValues * sizeof(float));
  }
  out.values.insert(out.values.end(), filled.values.begin() + handed_ * columns,
                    filled.values.begin() + (handed_ + count) * columns);
  handed_ += count;
  // Keep the last history_ frames handed out: a later gap's context, and
  // what the borrowed fill searches.
  const int64_t drop = std::max<int64_t>(0, handed_ - history_);
  given_.values.erase(given_.values.begin(), given_.values.begin() + drop * columns);
  decoded_.values.erase(decoded_.values.begin(), decoded_.values.begin() + drop * columns);
  if (borrows()) as_given_.values.erase(as_given_.values.begin(), as_given_.values.begin() + drop * columns);
  most_missing_.erase(most_missing_.begin(), most_missing_.begin() + drop);
  handed_ -= drop;
  first_ += drop;
}

}  // namespace mm
