// The transition benchmark (docs/RESULTS.md, "Gaps"): pairs of clips cut
// from recorded takes of different actions, joined by a transition of each
// length (clip_transition.h), generated and crossfaded, measured on the
// transition: the border jump (the larger of the moves into and out of it,
// mean over every joint but the root, mm/frame, against the median move of
// the two clips' recorded frames), the foot-skating ratio of the transition
// with 1 s on each side (foot_contacts.h), and how far its poses are from
// real motion as the manifold gives it back: each pose's distance (mean
// over the joints, mm, forward kinematics with the root at the origin and
// the root's rotation removed, so that a heading costs nothing) to the
// nearest pose of the manifold's reconstructions of the takes (take
// reconstruct, every 5th frame). The same distance of the clips' own
// recorded frames beside the transition is given for scale.
//
// Thread safety: reads the model only.
#pragma once

#include <cstdint>
#include <vector>

#include "model/clip_transition.h"
#include "model/gap_evaluation.h"

namespace mm {

struct TransitionBenchmarkOptions {
  std::vector<double> seconds = {0.5, 1.0, 2.0, 4.0};  // transition lengths
  double clip_seconds = 5.0;  // each clip's length, cut at a seeded place of its take
  uint64_t seed = 0;
  DecoderKind decoder = DecoderKind::kRotation;
  GapFillOptions fill;  // the generated transition's
  GapCodeFitOptions code_fit;
};

// Each take i is paired with take i + n/2 (of n; H3.6M's takes listed by
// action make that another action). InputError when fewer than two takes
// are long enough for a clip.
GapBenchmarkResult run_transition_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                            const TransitionBenchmarkOptions& options);

}  // namespace mm
