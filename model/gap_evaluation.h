// The gap benchmark (docs/RESULTS.md, "Gaps"): recorded takes with joints
// made missing for a while at seeded places, filled through the take
// denoise path and by interpolation, measured against the recording.
//
// Each take is run through the model (denoise, 25 Hz, the missing values
// NaN) once per round with its own gaps, at least `spacing_seconds` apart so
// that no window of the model holds two (a window is 6 s); the gaps of a
// round cycle through every length x joint count in a seeded order, so
// every configuration gets about the same number of places. Every method
// fills the same gaps of the same run: hold, slerp, cubic (gap_interpolation.h),
// the manifold's fill as keep_observed gave it before ("manifold"), the
// take's own windows' movement ("matched"), the fitted fill ("fitted") and
// the default, the take's own stretches where like enough, of the whole
// body or else of the model's legs and upper body apart, as the take path
// searches them ("borrowed", options.fill with body_parts(); in the JSON
// "borrow_ungated" takes every stretch found, "borrowed_whole_body"
// searches the whole body alone).
//
// Measures on the gap frames, at 25 Hz, positions by forward kinematics
// with the root at the origin (as Table 1's): MPJPE over the joints a
// missing rotation moves (the missing joints' descendants; every joint but
// the root when every joint is missing), mm; the angle between filled and
// recorded rotations of the missing joints, degrees; the border jump, the
// larger of the moves into and out of the gap (mean over the same joints,
// mm/frame) against the take's median move of those joints; the speed
// ratio, the joints' movement across the gap over the recording's; and the
// foot-skating ratio (foot_contacts.h) of the gap with 1 s on each side.
//
// Thread safety: reads the model only.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "model/gap_code_fit.h"
#include "model/gap_interpolation.h"
#include "model/motion_manifold.h"

namespace mm {

struct GapBenchmarkTake {
  std::string name;    // e.g. "walking_1"
  std::string action;  // e.g. "walking"
  MotionFrames frames; // at 25 Hz
};

struct GapBenchmarkOptions {
  std::vector<double> gap_seconds = {0.2, 0.5, 1.0, 2.0, 4.0};
  std::vector<int> joint_counts = {1, 5, 0};  // 0: every joint
  int rounds = 2;                // runs of each take, each with its own gaps
  double spacing_seconds = 6.5;  // at least this between gaps of one run
  uint64_t seed = 0;
  DecoderKind decoder = DecoderKind::kRotation;
  GapFillOptions fill;  // the "fitted" method's
  GapCodeFitOptions code_fit;
};

struct GapBenchmarkResult {
  std::string json;      // every configuration, method and action
  std::string markdown;  // the tables docs/RESULTS.md shows
};

// InputError when no take is long enough to hold a gap.
GapBenchmarkResult run_gap_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                     const GapBenchmarkOptions& options);

// In-betweening from sparse keyframes: each take (its first
// `take_seconds`) keeps the pose of one frame every `interval` seconds (the
// root translation of every frame, as a take's cannot be missing), every
// other joint value is missing; filled through the same path as gaps
// (process_take denoise, fit_gap_codes, fill_gaps) and by slerp and the
// cubic (Catmull-Rom tangents from the neighbouring keyframes) of the same
// keyframes. Measured on the frames between keyframes as above (MPJPE over
// every joint but the root, angle error, speed ratio, skating), and the
// largest angle (degrees) between a keyframe's given and returned rotations.
struct KeyframeBenchmarkOptions {
  std::vector<double> intervals = {0.5, 1.0, 2.0};  // seconds between keyframes
  double take_seconds = 30;                         // of each take (at least one window)
  DecoderKind decoder = DecoderKind::kRotation;
  GapFillOptions fill;  // the "fitted" method's
  GapCodeFitOptions code_fit;
};

// InputError when no take is one window long.
GapBenchmarkResult run_keyframe_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                          const KeyframeBenchmarkOptions& options);

}  // namespace mm
