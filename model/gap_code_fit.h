// The manifold's fill of a take's gaps from a code fitted to what was
// observed around each gap.
//
// The take path fills a gap from the windows it cuts the take into anyway
// (6 s every 3 s): a gap may sit at a window's edge with little observed
// on one side, and each window's code comes from the encoder reading the
// gap as the training mean and then its own fill (project_onto_manifold,
// four rounds). Here every gap (a run of frames where any joint is missing,
// the runs of several joints that touch taken as one) gets a window of the
// model's clip centred on it, and that window's code is fitted to the
// observed values around the gap by the decoder itself: from the encoder's
// code, a few Adam steps on the mean squared error of the decoded observed
// values (normalised), plus the prior's pull towards zero (the latent is
// N(0, I) under the training's KL term), the decoded gap then being the
// manifold's guess of the motion the observed frames on both sides belong to.
//
// The result is read as the "manifold" frames of gap_interpolation.h's
// matched fill, which lays its movement over the interpolation of the
// observed borders.
//
// Thread safety: reads the model only; may run concurrently on one model.
// Costs about `iterations` decoder passes forward and back per gap (on
// two CPU cores about 60 ms each), all gaps of a motion in one batch.
#pragma once

#include "format/motion_text.h"
#include "motion_manifold.h"

namespace mm {

struct GapCodeFitOptions {
  int iterations = 15;          // Adam steps on the code; 0: the encoder's code
  double learning_rate = 0.1;   // Adam's step on the code (the latent is N(0, I))
  double prior_weight = 1e-3;   // weight of mean(z^2) against the observed values' mean squared error
  int encoder_rounds = 4;       // rounds of project_onto_manifold giving the first code
  // Gaps shorter than this keep the take path's frames: the matched fill
  // lays no detail over them (GapFillOptions::interpolate_below_seconds),
  // so a fit would be spent for nothing.
  double min_seconds = 0.6;
};

// `decoded` (the take path's output for `observed`, same shape, 25 Hz) with
// the frames of each gap and two frames either side replaced by the decoded
// clip of the gap's centred window, its code fitted as described above.
// Gaps shorter than options.min_seconds, or longer than the clip less 2 s, keep `decoded`'s frames (too little
// observed to fit to). A motion shorter than one clip is returned as
// `decoded`. InputError when shapes differ.
MotionFrames fit_gap_codes(const MotionManifold& model, const MotionFrames& observed, const MotionFrames& decoded,
                           DecoderKind kind, const GapCodeFitOptions& options = {});

}  // namespace mm
