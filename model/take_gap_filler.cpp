#include "model/take_gap_filler.h"

#include <algorithm>
#include <cstring>

namespace mm {

TakeGapFiller::TakeGapFiller(int columns, GapFillOptions options, double rate_hz)
    : options_(options), rate_hz_(rate_hz) {
  given_.columns = decoded_.columns = columns;
}

void TakeGapFiller::push(const MotionFrames& given, const MotionFrames& decoded, MotionFrames& out) {
  given_.values.insert(given_.values.end(), given.values.begin(), given.values.end());
  decoded_.values.insert(decoded_.values.end(), decoded.values.begin(), decoded.values.end());
  const int64_t held = given_.frame_count();
  // Hand out the frames before the first gap that is not final: one whose
  // right border or the frame after it has not arrived (the cubic needs
  // it), keeping the frame before its left border for the same reason.
  // A final gap is handed out whole or not at all.
  const auto gaps = find_joint_gaps(given_);
  int64_t end = held;
  for (const JointGap& gap : gaps) {
    if (gap.last + 2 >= held) end = std::min(end, gap.first - 2);
  }
  for (bool moved = true; moved;) {
    moved = false;
    for (const JointGap& gap : gaps) {
      if (end > gap.first - 2 && end <= gap.last) {
        end = gap.first - 2;
        moved = true;
      }
    }
  }
  hand_out(std::max<int64_t>(end, 0), out);
}

void TakeGapFiller::finish(MotionFrames& out) { hand_out(given_.frame_count(), out); }

void TakeGapFiller::hand_out(int64_t count, MotionFrames& out) {
  if (count <= 0) return;
  // Every gap held is filled again from the held frames: a gap's fill reads
  // only its own borders and the frame beyond each, which stay held until
  // it is handed out.
  MotionFrames filled = fill_gaps(given_, &decoded_, options_, rate_hz_);
  const int columns = given_.columns;
  for (int64_t f = 0; f < count; ++f) {
    std::memcpy(filled.frame(f), decoded_.frame(f), kRootTranslationValues * sizeof(float));
  }
  out.values.insert(out.values.end(), filled.values.begin(), filled.values.begin() + count * columns);
  given_.values.erase(given_.values.begin(), given_.values.begin() + count * columns);
  decoded_.values.erase(decoded_.values.begin(), decoded_.values.begin() + count * columns);
}

}  // namespace mm
