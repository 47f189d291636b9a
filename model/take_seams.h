// How the joins between a take's windows show in its reconstruction: the
// measurement behind docs/RESULTS.md's seam table.
//
// A take is reconstructed at the model's 25 Hz (take_processor.h) with the
// windows crossfaded and with them cut (the later window from the middle of
// each overlap), and its joints placed by forward kinematics. At each seam
// (the transition where the cut switches windows) and at the transitions
// inside windows (at least kSeamMargin frames from any window's start, end
// or switch), it measures
// - the jump: the mean over joints of |p(t+1) - p(t)|, mm per frame;
// - the excess jump: the mean over joints of |(p(t+1) - p(t)) -
//   (q(t+1) - q(t))| against the input q, mm per frame: what the seam adds
//   to the motion's own change;
// - the jerk: the mean over joints of |p(t+2) - 3 p(t+1) + 3 p(t) - p(t-1)|,
//   mm per frame cubed (at 25 Hz);
// beside the input's own jump and jerk at the same transitions, the take's
// per-frame error, and the error of the same windows reconstructed one by
// one as single 6 s clips (what the service gave before takes).
//
// Thread safety: reentrant; the model's inference is const.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "model/motion_manifold.h"
#include "model/take_assembly.h"

namespace mm {

constexpr int kSeamMargin = 5;  // frames at 25 Hz

struct TransitionStatistics {
  int64_t transitions = 0;
  double jump_mm = 0;         // reconstruction, mean over the transitions
  double excess_jump_mm = 0;  // reconstruction against the input
  double jerk_mm = 0;
  double input_jump_mm = 0;   // the input's own
  double input_jerk_mm = 0;
};

struct BlendSeams {
  TakeBlend blend = TakeBlend::kCrossfade;
  TransitionStatistics seams, inside;
  double mean_error_mm = 0;           // per-frame error of the whole take at 25 Hz
  std::vector<float> error_mm;        // per frame at 25 Hz
};

struct TakeSeams {
  std::string name;
  int64_t frames = 0;  // at 25 Hz
  int windows = 0;
  double hop_seconds = 0;
  std::vector<int64_t> window_starts;  // 25 Hz frames
  std::vector<int64_t> seam_transitions;  // t of each seam t -> t + 1 (the cut's switch), 25 Hz frames
  BlendSeams crossfade, cut;
  // The take's windows reconstructed alone, as single clips: their mean
  // per-frame error, mm.
  double single_clip_error_mm = 0;
};

// Measures one take given at 25 Hz (the model's columns). InputError as the
// take operations give (a take shorter than a window, a bad hop).
TakeSeams measure_take_seams(const MotionManifold& model, const MotionFrames& take_at_25_hz, const std::string& name,
                             double hop_seconds, DecoderKind decoder);

}  // namespace mm
