// A take's gaps given the manifold's frames of codes fitted to them, as the
// take's frames arrive: the take processor's keep_observed path with the
// fitted fill (take_processor.h, GapMethod::kFitted) hands each 25 Hz input
// frame (NaN where missing) and each assembled 25 Hz output frame here, and
// gets back the output frames no fit will change any more, with each gap's
// frames and two either side replaced by the clip of the gap's centred
// window, its code fitted to the observed values (gap_code_fit.h). The
// matched fill (take_gap_filler.h) then lays that clip's movement over the
// cubic across the gap.
//
// The windows are those fit_gap_codes() makes on the whole take: the same
// gaps (gap_gets_fitted: none between lone keyframes, so known once the
// frame after next of the gap has arrived), joined by the same rule,
// centred the same way, the same ones left unfitted beyond
// GapCodeFitOptions::max_windows. A window is fitted once every observed
// frame of it has arrived and no later gap can join it;
// output frames are held from two frames before the earliest gap whose
// window is not fitted yet. So the extra latency is at most half a window
// (3 s) after a gap, and what is held depends on the gaps, never on the
// take's length.
//
// Used by one thread at a time; the fits run through the TorchRunner given.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <vector>

#include "format/motion_frames.h"
#include "model/gap_code_fit.h"

namespace mm {

class TakeGapFitter {
 public:
  // `run` runs a fit's tensor work (empty: on the calling thread).
  TakeGapFitter(const MotionManifold& model, DecoderKind kind, GapCodeFitOptions options,
                std::function<void(const std::function<void()>&)> run);

  // The next 25 Hz input frames (NaN where missing), in order. They arrive
  // before the output frames of the same times.
  void observe(const MotionFrames& observed);
  // The next assembled 25 Hz output frames. Appends to `out` the frames now
  // final. `last`: the take has ended (every input frame observed, these
  // the last output frames): everything held is handed out.
  void push(const MotionFrames& decoded, bool last, MotionFrames& out);

  int64_t held_frames() const { return static_cast<int64_t>(observed_.size() / columns_) + decoded_.frame_count(); }
  const GapFitCounts& counts() const { return counts_; }

 private:
  // A gap has ended (its next frame observed): it waits in ended_span_
  // for its frame after next when its length may be fitted.
  void end_span(const FrameSpan& span);
  // The ended gap's frames up to `arrived_end` (exclusive: its frame after
  // next, or the take's end) have arrived: it joins a window if fitted.
  void settle_ended_span(int64_t arrived_end);
  void take_span(const FrameSpan& span);
  void close_open_window();
  // Fits the windows in order while the first is ready.
  void fit_ready_windows(bool ended);
  const float* observed_frame(int64_t f) const {
    return observed_.data() + static_cast<size_t>((f - observed_first_) * columns_);
  }

  const MotionManifold& model_;
  DecoderKind kind_;
  GapCodeFitOptions options_;
  std::function<void(const std::function<void()>&)> run_;
  int columns_;
  int64_t window_;

  // 25 Hz input frames from observed_first_ (what a window not yet fitted
  // may read), and how many have arrived.
  std::vector<float> observed_;
  int64_t observed_first_ = 0, observed_end_ = 0;
  int64_t open_span_first_ = -1;  // a gap still running at observed_end_
  std::optional<FrameSpan> ended_span_;  // a gap ended whose frame after next has not arrived
  // Windows taking gaps (open_) and closed ones waiting for their fit, in order.
  GapFitWindow open_;
  std::deque<GapFitWindow> closed_;
  int windows_planned_ = 0;
  // Output frames from decoded_first_ (the first not handed out), and which
  // are a fitted gap's own frames (write_fitted_window's marks).
  MotionFrames decoded_;
  int64_t decoded_first_ = 0;
  std::vector<bool> written_;
  GapFitCounts counts_;
};

}  // namespace mm
