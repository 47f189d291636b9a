#include "model/take_gap_fitter.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "model/take_windows.h"

namespace mm {
namespace {

// A gap still running may get a window only while it is no longer than a
// fitted gap may be (gap_length_is_fitted): past that nothing waits for it,
// so a joint missing for the rest of a long take holds nothing here.
bool may_get_window(int64_t first, int64_t end, int64_t window) {
  return first >= 0 && end - first <= window - static_cast<int64_t>(2 * kTakeModelRate);
}

}  // namespace

TakeGapFitter::TakeGapFitter(const MotionManifold& model, DecoderKind kind, GapCodeFitOptions options,
                             std::function<void(const std::function<void()>&)> run)
    : model_(model),
      kind_(kind),
      options_(options),
      run_(std::move(run)),
      columns_(model.normalization().input_columns()),
      window_(model.config().frames) {
  decoded_.columns = columns_;
}

void TakeGapFitter::observe(const MotionFrames& observed) {
  const int64_t count = observed.frame_count();
  observed_.insert(observed_.end(), observed.values.begin(), observed.values.end());
  for (int64_t i = 0; i < count; ++i) {
    const int64_t f = observed_end_ + i;
    const float* v = observed.frame(i);
    bool missing = false;
    for (int c = kRootTranslationValues; c < columns_ && !missing; ++c) missing = std::isnan(v[c]);
    // The frame after next of an ended gap has arrived (frame f is in
    // observed_ already): whether its borders are lone keyframes is known.
    if (ended_span_ && f == ended_span_->last + 2) settle_ended_span(f + 1);
    if (missing && open_span_first_ < 0) open_span_first_ = f;
    if (!missing && open_span_first_ >= 0) {
      end_span({open_span_first_, f - 1});
      open_span_first_ = -1;
    }
  }
  observed_end_ += count;
  // No gap still to come can join the open window once every frame up to
  // the last a joining gap may end at, the one after it, and the one after
  // that (which settles whether it is fitted), has arrived.
  if (!open_.spans.empty()) {
    const int64_t last_joining = open_.spans.front().first + window_ - static_cast<int64_t>(2 * kTakeModelRate) - 1;
    if (observed_end_ >= last_joining + 3) close_open_window();
  }
  // Keep what a window not fitted yet may read: it is centred on gaps from
  // the earliest pending one on, or (at the take's end) its last clip.
  int64_t pending = may_get_window(open_span_first_, observed_end_, window_) ? open_span_first_ : observed_end_;
  if (ended_span_) pending = std::min(pending, ended_span_->first);
  if (!open_.spans.empty()) pending = std::min(pending, open_.spans.front().first);
  if (!closed_.empty()) pending = std::min(pending, closed_.front().spans.front().first);
  const int64_t keep_from = std::max<int64_t>(observed_first_, std::min(pending, observed_end_) - window_);
  if (keep_from > observed_first_) {
    observed_.erase(observed_.begin(), observed_.begin() + static_cast<std::ptrdiff_t>((keep_from - observed_first_) * columns_));
    observed_first_ = keep_from;
  }
}

void TakeGapFitter::end_span(const FrameSpan& span) {
  if (gap_length_is_fitted(span, window_, options_)) ended_span_ = span;
}

void TakeGapFitter::settle_ended_span(int64_t arrived_end) {
  const FrameSpan span = *ended_span_;
  ended_span_.reset();
  // The frames gap_gets_fitted reads: from two before the gap (kept, as
  // the gap is pending) to two after it, or the take's end.
  const int64_t from = std::max<int64_t>(observed_first_, span.first - 2);
  const int64_t to = std::min(arrived_end, span.last + 3);
  MotionFrames around;
  around.columns = columns_;
  around.values.assign(observed_frame(from), observed_frame(from) + static_cast<std::ptrdiff_t>((to - from) * columns_));
  if (gap_gets_fitted(around, from, span, window_, options_)) take_span(span);
}

void TakeGapFitter::take_span(const FrameSpan& span) {
  if (!gap_joins_window(open_, span, window_)) close_open_window();
  open_.spans.push_back(span);
}

void TakeGapFitter::close_open_window() {
  if (open_.spans.empty()) return;
  closed_.push_back(std::move(open_));
  open_ = {};
}

void TakeGapFitter::fit_ready_windows(bool ended) {
  const int64_t decoded_end = decoded_first_ + decoded_.frame_count();
  std::vector<GapFitWindow> ready;
  while (!closed_.empty()) {
    GapFitWindow& fit = closed_.front();
    if (options_.max_windows > 0 && windows_planned_ >= options_.max_windows) {
      counts_.gaps_over_limit += static_cast<int>(fit.spans.size());
      ++windows_planned_;
      closed_.pop_front();
      continue;
    }
    // The centred window's start is final once its end has arrived: the
    // take is at least that long, so the clamp to its end cannot move it.
    const int64_t first = fit.spans.front().first, last = fit.spans.back().last;
    const int64_t centred = std::max<int64_t>(0, (first + last + 1) / 2 - window_ / 2);
    if (!ended && centred + window_ > observed_end_) break;
    fit.start = ended ? centred_window_start(fit, observed_end_, window_) : centred;
    // Its writes reach two frames past its last gap.
    if (std::min(fit.start + window_ - 1, last + 2) >= decoded_end) break;
    ready.push_back(std::move(fit));
    closed_.pop_front();
    ++windows_planned_;
  }
  if (ready.empty()) return;
  std::vector<const float*> windows;
  for (const GapFitWindow& fit : ready) windows.push_back(observed_frame(fit.start));
  std::vector<std::vector<float>> clips;
  std::vector<double> errors;
  auto work = [&] { clips = fit_window_clips(model_, windows, kind_, options_, &errors); };
  if (run_) {
    run_(work);
  } else {
    work();
  }
  // In order, each window's borders then its gaps: write_fitted_window's
  // marks keep a gap's frames from a later window's borders, which gives
  // what fit_gap_codes() writes on the whole take.
  for (size_t i = 0; i < ready.size(); ++i) {
    ready[i].observed_error = errors[i];
    ready[i].lays_detail = window_lays_detail(ready[i], windows[i], columns_, options_);
    for (const bool gap_frames : {false, true}) {
      write_fitted_window(ready[i], clips[i].data(), window_, gap_frames, decoded_, decoded_first_, written_);
    }
    ++counts_.windows_fitted;
    counts_.gaps_fitted += static_cast<int>(ready[i].spans.size());
  }
}

void TakeGapFitter::push(const MotionFrames& decoded, bool last, MotionFrames& out) {
  decoded_.values.insert(decoded_.values.end(), decoded.values.begin(), decoded.values.end());
  written_.resize(static_cast<size_t>(decoded_.frame_count()), false);
  if (last) {
    // The take has ended: an ended gap's frame after next will not come,
    // and a gap running to the take's end ends there.
    if (ended_span_) settle_ended_span(observed_end_);
    if (open_span_first_ >= 0) end_span({open_span_first_, observed_end_ - 1});
    open_span_first_ = -1;
    if (ended_span_) settle_ended_span(observed_end_);
    close_open_window();
  }
  fit_ready_windows(last);
  // Hand out the frames no window still to fit writes: those before two
  // frames ahead of the earliest gap that may still get a window.
  int64_t end = decoded_first_ + decoded_.frame_count();
  if (!last) {
    end = std::min(end, observed_end_ - 2);
    if (may_get_window(open_span_first_, observed_end_, window_)) end = std::min(end, open_span_first_ - 2);
    if (ended_span_) end = std::min(end, ended_span_->first - 2);
    if (!open_.spans.empty()) end = std::min(end, open_.spans.front().first - 2);
    if (!closed_.empty()) end = std::min(end, closed_.front().spans.front().first - 2);
  }
  const int64_t count = std::max<int64_t>(0, end - decoded_first_);
  if (count == 0) return;
  const auto floats = static_cast<std::ptrdiff_t>(count * columns_);
  out.values.insert(out.values.end(), decoded_.values.begin(), decoded_.values.begin() + floats);
  decoded_.values.erase(decoded_.values.begin(), decoded_.values.begin() + floats);
  written_.erase(written_.begin(), written_.begin() + static_cast<std::ptrdiff_t>(count));
  decoded_first_ += count;
}

}  // namespace mm
