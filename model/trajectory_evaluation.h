// Measuring generated root paths and planted feet against recorded motion:
// what docs/RESULTS.md's trajectory and skating tables report.
//
// Paths are the root's horizontal path (the running sum of columns 0 and 2,
// mm), both starting at the origin in frame 0 (the start aligned). Over a
// set of clips at `rate_hz`:
// - path error: the mean over frames of the distance between the paths;
// - final displacement error: that distance at the last frame;
// - both also as a share of the distance travelled (summed over clips, so
//   a clip standing still weighs nothing rather than infinitely);
// - speed error: the mean absolute difference of the root's horizontal
//   speed, frame to frame;
// - heading error: the mean angle between the directions the two paths
//   travel over each half second (13 frames at 25 Hz), over the half
//   seconds in which the recorded root moves at least 50 mm; undefined for
//   a path that stands still.
//
// Thread safety: pure functions.
#pragma once

#include <optional>
#include <vector>

#include "format/foot_contacts.h"
#include "format/motion_frames.h"

namespace mm {

struct PathErrors {
  int clips = 0;
  double distance_mm = 0;          // mean recorded distance travelled per clip
  double path_error_mm = 0;
  double path_error_share = 0;     // of the distance travelled
  double final_error_mm = 0;
  double final_error_share = 0;
  double speed_error_mm_s = 0;
  std::optional<double> heading_error_deg;  // none when the prediction never moves
};

// `predicted[i]` against `recorded[i]` (same frame counts). InputError for
// different counts.
PathErrors compare_root_paths(const std::vector<MotionFrames>& recorded, const std::vector<MotionFrames>& predicted,
                              double rate_hz);

// The baseline a user would try first: the recorded root's mean change over
// the first second held for the whole clip (copies of `recorded` with that
// path).
std::vector<MotionFrames> held_first_second_roots(const std::vector<MotionFrames>& recorded, double rate_hz);

// Copies with no root motion (columns 0 and 2 zero).
std::vector<MotionFrames> standing_roots(const std::vector<MotionFrames>& motions);

// The skating ratio (format/foot_contacts.h) over a set of motions: frames
// with a skating foot of all frames.
SkatingCount total_skating(const Skeleton& skeleton, const std::vector<MotionFrames>& motions, double rate_hz,
                           const FootContactThresholds& thresholds = {});

}  // namespace mm
