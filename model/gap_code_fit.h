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

#include <cstdint>
#include <vector>

#include "format/motion_frames.h"
#include "model/gap_interpolation.h"
#include "model/motion_manifold.h"

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
  // The most windows fitted in one motion (0: no limit), in order of time:
  // the gaps of later windows keep the take path's frames (the matched fill
  // over the take's own windows). A fit costs about `iterations` decoder
  // passes forward and back: 12 s of CPU a window in the benchmark's
  // batches, 36 s for one window alone, on the two busy cores here (load
  // 8), so this bounds what a take of many gaps costs before the work is
  // done: at most about 12 minutes of CPU at that load whatever the take
  // (docs/RESULTS.md, "Gaps").
  int max_windows = 20;
  // A window of in-betweening (a gap with most joints missing at its middle,
  // as GapFillOptions tells most joints from a few) whose fitted code meets
  // its observed values worse than this (GapFitWindow::observed_error) lays
  // no detail over its gaps: their frames are written missing (NaN), which
  // the matched fill reads as the cubic alone (gap_interpolation.h), since a
  // code that misses the whole body around a gap is no guide to the gap.
  // Chosen from the gap records of the benchmark (docs/RESULTS.md "Gaps"):
  // 0.3 is the tightest bound that costs the training subjects' every-joint
  // gaps under 2%, and over three runs it brings S5's every-joint gaps of
  // 2 s 5% nearer (106 gaps) and leaves those of 4 s level. Windows of a
  // few joints' gaps are not bounded: there the error is mostly that of the
  // joints observed through the gap, and bounding them cost S5's gaps of 1
  // and 5 joints up to 24%. Infinity: no bound.
  double max_observed_error = 0.3;
};

// One window of the model's clip fitted to the observed values around the
// gaps it holds: the gaps (in order) and the window's first frame.
struct GapFitWindow {
  std::vector<FrameSpan> spans;
  int64_t start = 0;
  // After the fit: the mean squared error of the fitted code's decoded
  // values against the window's observed ones (normalised, as the fit's loss).
  double observed_error = 0;
  // Whether its gaps get its clip (window_lays_detail) or are written missing.
  bool lays_detail = true;
};

// Whether a fitted window lays its clip's detail over its gaps: its
// observed_error within options.max_observed_error, or none of its gaps
// in-betweening (most joints missing at the gap's middle frame).
// `window_values`: the window's observed values (the model's clip from
// fit.start, `columns` values a frame, NaN where missing).
bool window_lays_detail(const GapFitWindow& fit, const float* window_values, int columns,
                        const GapCodeFitOptions& options);

// The rules by which gaps get windows, shared by the whole-motion fit below
// and the take path's streaming one (take_gap_fitter.h), so that both make
// the same windows. `window`: the model's clip in frames (25 Hz).
// A gap is fitted when it lasts options.min_seconds up to the clip less 2 s
// (gap_length_is_fitted) and the fill lays the fitted clip's detail over
// some joint's gap in it: not every one of them has a lone keyframe for a
// border (gap_borders_lone_keyframe, gap_interpolation.h: the fill lays
// only the cubic there, so the fit would be thrown away, and a take of
// sparse keyframes would spend the max_windows on nothing). `observed`
// holds the motion's frames (NaN where missing) from its frame
// `observed_first` on: at least span.first - 2 .. span.last + 2, fewer only
// where the motion begins or ends; its end is taken as the motion's where
// it comes before span.last + 2.
bool gap_gets_fitted(const MotionFrames& observed, int64_t observed_first, const FrameSpan& span, int64_t window,
                     const GapCodeFitOptions& options);
bool gap_length_is_fitted(const FrameSpan& span, int64_t window, const GapCodeFitOptions& options);
// Gaps near each other share a window (sparse keyframes make a gap between
// every two): a window takes gaps while they span at most the clip less 2 s.
bool gap_joins_window(const GapFitWindow& fit, const FrameSpan& span, int64_t window);
// The window centred on the fit's gaps, within a motion of `frames` frames.
int64_t centred_window_start(const GapFitWindow& fit, int64_t frames, int64_t window);

// Fits one code to each of `windows` (each the model's clip of observed
// values, raw, window x columns, NaN where missing) and returns each
// code's decoded clip (raw, window x columns). All windows in one batch.
// `observed_errors`, when given, gets each window's GapFitWindow::observed_error.
std::vector<std::vector<float>> fit_window_clips(const MotionManifold& model, const std::vector<const float*>& windows,
                                                 DecoderKind kind, const GapCodeFitOptions& options,
                                                 std::vector<double>* observed_errors = nullptr);

// Writes a fitted window's clip into `out` (frame f of the motion is
// out.frame(f - out_first)): the frames two either side of each gap (the
// matched fill reads the manifold's borders and their velocities) when
// `gap_frames` is false, skipping those `written` marks; the gaps' own
// frames when true, marking them in `written` (same indexing), as missing
// (NaN) where the window lays no detail (GapFitWindow::lays_detail).
// Written in that order over every window, a gap's frames are never
// another window's border frames.
void write_fitted_window(const GapFitWindow& fit, const float* clip, int64_t window, bool gap_frames,
                         MotionFrames& out, int64_t out_first, std::vector<bool>& written);

// `decoded` (the take path's output for `observed`, same shape, 25 Hz) with
// the frames of each gap and two frames either side replaced by the decoded
// clip of the gap's centred window, its code fitted as described above.
// Gaps shorter than options.min_seconds, or longer than the clip less 2 s,
// those between lone keyframes (gap_gets_fitted) and those of windows
// beyond options.max_windows keep `decoded`'s frames.
// A motion shorter than one clip is returned as `decoded`. InputError when
// shapes differ. `windows_fitted`, when given, gets the windows fitted and
// `gaps_fitted` the gaps they held; `gaps_over_limit` the gaps of windows
// beyond max_windows.
struct GapFitCounts {
  int windows_fitted = 0;
  int gaps_fitted = 0;
  int gaps_over_limit = 0;
};
// `windows`, when given, gets the windows fitted, with their observed_error.
MotionFrames fit_gap_codes(const MotionManifold& model, const MotionFrames& observed, const MotionFrames& decoded,
                           DecoderKind kind, const GapCodeFitOptions& options = {}, GapFitCounts* counts = nullptr,
                           std::vector<GapFitWindow>* windows = nullptr);

}  // namespace mm
