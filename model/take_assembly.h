// TakeAssembler: joins the windows decoded from a take back into one
// continuous motion at 25 Hz, frame by frame as the windows arrive.
//
// Windows come in order of their start (take_windows.h); where a window
// overlaps the frames assembled so far, the two are blended:
// - crossfade: frame t of the overlap [start, end of what came before)
//   becomes slerp_expmap(assembled, window, w) per joint, with w rising
//   linearly from 1 / (overlap + 1) to overlap / (overlap + 1), so the
//   blend is done on rotations; the root columns are blended linearly;
// - cut: the window replaces the assembled frames from the middle of the
//   overlap on (no blending: the seam the crossfade is measured against).
// Frames before a window's start can no longer change and are handed out.
//
// Thread safety: one thread at a time. Bad arguments throw InputError.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

enum class TakeBlend { kCrossfade, kCut };
const char* take_blend_name(TakeBlend blend);  // "crossfade" / "cut"
// Parses "crossfade" or "cut"; InputError "blend: expected crossfade or cut,
// found '<name>'" otherwise.
TakeBlend parse_take_blend(const std::string& name);

class TakeAssembler {
 public:
  TakeAssembler(int columns, TakeBlend blend);

  // Adds the window that starts at 25 Hz frame `start` and appends to `out`
  // the frames before `start`, now final. The first window starts at 0; each
  // next one at or after the previous start and at or before the end of what
  // is assembled (no frame left uncovered). InputError naming "start"
  // otherwise, or for a window of another column count or no frames.
  void add(int64_t start, const MotionFrames& window, MotionFrames& out);
  // Appends the frames not yet handed out. Returns the total frame count.
  int64_t finish(MotionFrames& out);

  int64_t assembled_frames() const { return first_pending_ + pending_.frame_count(); }

 private:
  int columns_;
  TakeBlend blend_;
  MotionFrames pending_;       // frames [first_pending_, end), not yet final
  int64_t first_pending_ = 0;  // 25 Hz frame index of pending_'s first frame
  int64_t last_start_ = -1;
};

}  // namespace mm
