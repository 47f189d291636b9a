// What a take operation did, once it has ended: one type from the model's
// TakeProcessor and decode_code_track (model/take_processor.h) through the
// core (server/core/take_session.h) to the frontends, which write it as
// gRPC's TakeSummary and CodeTrack and REST's JSON `summary` and X-Take-*
// headers (server/translation/proto_translation.h names which field goes
// where).
//
// Torch-free and wire-free: the frontends include it.
#pragma once

#include <cstdint>

namespace mm {

struct TakeSummary {
  // The take as it came in: its frames and their rate in Hz (0 for a code
  // track decoded, which has no input frames).
  int64_t input_frames = 0;
  double input_rate = 0;
  // Frames at 25 Hz the take was windowed at (the track's length for a code
  // track decoded).
  int64_t model_frames = 0;
  // The frames answered and their rate in Hz: the take's rate, or 25 with
  // at_model_rate, or a decoded track's rate. Encode answers no frames:
  // 0 of them, at the rate they would have come.
  int64_t output_frames = 0;
  double output_rate = 0;
  // The windows run through the model, the model's window (its clip) and
  // the hop between windows, in seconds (the hop as rounded to 25 Hz frames;
  // 0 for a code track decoded, whose windows start where the track says).
  int windows = 0;
  double window_seconds = 0;
  double hop_seconds = 0;
  // Reconstruct and denoise: each output frame's mean joint distance (mm)
  // from the input by forward kinematics, averaged over the output frames,
  // and the largest.
  double mean_error_mm = 0;
  double max_error_mm = 0;
  // Denoise with keep_observed and the fitted fill: the windows fitted, the
  // gaps (runs of frames where any joint is missing, at 25 Hz) they held,
  // and the gaps left to the matched fill because the take had more windows
  // to fit than the bound (GapCodeFitOptions::max_windows, the server's
  // --max-take-gap-fits).
  int gap_windows_fitted = 0;
  int gaps_fitted = 0;
  int gaps_over_fit_limit = 0;
};

}  // namespace mm
