#include "model/take_processor.h"

#include "format/foot_contacts.h"
#include "format/root_path.h"

#include <c10/core/InferenceMode.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <stdexcept>

#include "format/input_error.h"
#include "format/motion_resampling.h"
#include "format/motion_text.h"
#include "model/borrowed_motion.h"
#include "model/take_gap_filler.h"
#include "model/take_gap_fitter.h"

namespace mm {
namespace {

// Input frames the processor takes in one step: a push of a whole take is
// worked through in pieces, so that what it holds stays bounded.
constexpr int64_t kPushStepFrames = 2048;

std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

void run_tensor_work(const TorchRunner& run, const std::function<void()>& work) {
  if (run) {
    run(work);
  } else {
    work();
  }
}

// Frames in arrival order, indexed from the take's start; the oldest are
// dropped once nothing needs them.
class FrameQueue {
 public:
  explicit FrameQueue(int columns) : columns_(columns) {}

  void append(const float* values, int64_t frames) { values_.insert(values_.end(), values, values + frames * columns_); }
  void drop_before(int64_t index) {
    const int64_t drop = std::min(index, end()) - first_;
    if (drop <= 0) return;
    head_ += static_cast<size_t>(drop * columns_);
    first_ += drop;
    // Erase the dropped front once it is half the storage: amortised O(1).
    if (head_ * 2 >= values_.size()) {
      values_.erase(values_.begin(), values_.begin() + static_cast<std::ptrdiff_t>(head_));
      head_ = 0;
    }
  }
  const float* frame(int64_t index) const { return values_.data() + head_ + (index - first_) * columns_; }
  int64_t begin() const { return first_; }
  int64_t end() const { return first_ + size(); }
  int64_t size() const { return static_cast<int64_t>(values_.size() - head_) / columns_; }

 private:
  int columns_;
  std::vector<float> values_;
  size_t head_ = 0;  // floats of dropped frames still at the front of values_
  int64_t first_ = 0;
};

// Frames whose forward kinematics run at once: the tensors of a step stay
// in cache (measured on two cores: a 10-minute take at 120 Hz spends 1.0 s
// in the error's kinematics in steps of 1024 frames, 2.0 s in one step).
constexpr int64_t kKinematicsStepFrames = 1024;

// Mean joint distance (FK, mm) between each output frame and its reference.
std::vector<float> frame_errors_mm(const MotionManifold& model, const MotionFrames& output,
                                   const MotionFrames& reference, const TorchRunner& run) {
  const int64_t frames = output.frame_count();
  std::vector<float> errors(static_cast<size_t>(frames));
  run_tensor_work(run, [&] {
    c10::InferenceMode inference;
    auto all_output = at::from_blob(const_cast<float*>(output.values.data()), {frames, output.columns});
    auto all_reference = at::from_blob(const_cast<float*>(reference.values.data()), {frames, reference.columns});
    for (int64_t first = 0; first < frames; first += kKinematicsStepFrames) {
      const int64_t count = std::min(kKinematicsStepFrames, frames - first);
      auto both = at::cat({all_output.narrow(0, first, count), all_reference.narrow(0, first, count)});
      auto positions = model.positions_mm(model.to_normalized(both.to(model.device())));
      auto error = (positions.narrow(0, 0, count) - positions.narrow(0, count, count)).norm(2, -1).mean(-1);
      error = error.to(at::kFloat).cpu().contiguous();
      std::memcpy(errors.data() + first, error.data_ptr<float>(), static_cast<size_t>(count) * sizeof(float));
    }
  });
  return errors;
}

// The checks every take's options get before any frame is read.
void check_common_options(const MotionManifold& model, DecoderKind decoder, bool decodes, int batch_windows,
                          double max_seconds, const std::string& max_seconds_name) {
  if (decodes && !model.has_decoder(decoder)) {
    throw InputError("decoder", std::string("this model has no ") + decoder_name(decoder) + " decoder");
  }
  if (batch_windows < 1) throw InputError("batch_windows", "expected at least 1, found " + std::to_string(batch_windows));
  if (!(max_seconds >= 0) || !std::isfinite(max_seconds)) {
    throw InputError(max_seconds_name, "expected 0 (no limit) or a number of seconds, found " +
                     number_text(max_seconds));
  }
}

}  // namespace

struct TakeProcessor::State {
  State(const MotionManifold& m, TakeOptions o, TakeSink s, TorchRunner r)
      : model(m),
        options(std::move(o)),
        sink(std::move(s)),
        run(std::move(r)),
        columns(m.normalization().input_columns()),
        windowing(take_windowing(m.config().frames, options.hop_seconds)),
        to_model(columns, options.frame_rate, kTakeModelRate),
        assembler(columns, options.blend),
        model_frames(columns),
        reference(columns) {
    if (answers() && !options.at_model_rate) to_output.emplace(columns, kTakeModelRate, options.frame_rate);
    if (denoises() && options.denoise.keep_observed) {
      // Where no stretch of the whole body is like enough, the borrowed fill
      // searches the legs and the upper body apart, which only the model's
      // skeleton tells (BorrowOptions::parts).
      GapFillOptions fill = options.gap_fill;
      fill.borrow.parts = body_parts(m.skeleton());
      gap_filler.emplace(columns, fill, options.at_model_rate ? kTakeModelRate : options.frame_rate);
      if (reads_fitted_codes(options.gap_fill.method)) {
        gap_fitter.emplace(model, options.decoder, options.gap_fit,
                           [this](const std::function<void()>& work) { run_tensor_work(run, work); });
      }
    }
  }

  bool answers() const { return options.operation != TakeOperation::kEncode; }
  bool denoises() const { return options.operation == TakeOperation::kDenoise; }
  // The frames replies are answered against are the input's, or at 25 Hz
  // its resampled frames.
  bool reference_at_model_rate() const { return options.at_model_rate; }

  void check_values(const float* values, int64_t frames) const;
  void take_input(const float* values, int64_t frames);
  void take_model_frames(const MotionFrames& frames);
  void run_ready_windows(size_t at_least);
  void run_batch(const std::vector<int64_t>& starts);
  void hand_out_assembled(const MotionFrames& assembled, bool last);
  void answer(MotionFrames& output, bool last);
  void note_held(int64_t extra = 0) {
    const int64_t held = model_frames.size() + reference.size() + (assembler.assembled_frames() - assembled_out) + extra;
    held_peak = std::max(held_peak, held);
  }

  const MotionManifold& model;
  TakeOptions options;
  TakeSink sink;
  TorchRunner run;
  int columns;
  TakeWindowing windowing;
  MotionResampler to_model;                 // input rate -> 25 Hz
  std::optional<MotionResampler> to_output; // 25 Hz -> input rate
  TakeAssembler assembler;
  FrameQueue model_frames;  // 25 Hz frames from the first window not yet run on
  FrameQueue reference;     // frames not yet answered (input rate, or 25 Hz)
  std::vector<int64_t> ready_starts;  // windows whose frames have all arrived
  int64_t next_start = 0;             // the next regular window's start
  int64_t last_queued_start = -1;
  int64_t assembled_out = 0;  // 25 Hz frames the assembler handed out
  int64_t input_frames = 0;
  int64_t output_frames = 0;
  int windows = 0;
  double error_sum = 0, error_max = 0;
  // The generated root: its path so far and the floor under it (a take is
  // not held whole, so the floor follows the last 2 s of frames instead of
  // levelling the whole path).
  std::optional<RootPathIntegrator> root_path;
  std::optional<StreamingFloor> floor;
  // Denoise with keep_observed: the frames of gaps not yet final, and with
  // the fitted fill the 25 Hz frames of gaps whose windows are not fitted yet.
  std::optional<TakeGapFiller> gap_filler;
  std::optional<TakeGapFitter> gap_fitter;
  int64_t held_peak = 0;
  bool finished = false;
};

void TakeProcessor::State::check_values(const float* values, int64_t frames) const {
  for (int64_t f = 0; f < frames; ++f) {
    const float* frame = values + f * columns;
    for (int c = 0; c < columns; ++c) {
      const float v = frame[c];
      const bool root = c < kRootTranslationValues;
      if (std::fabs(v) <= (root ? kMaxRootTranslationMm : kMaxRotationRadians)) continue;
      if (std::isnan(v) && denoises() && !root) continue;
      std::string where = "take frame " + std::to_string(input_frames + f) + ", column " + std::to_string(c) +
                          " (both counted from 0): found " + number_text(v) + ", expected ";
      if (std::isnan(v)) {
        where += root ? "a number: the root translation (columns 0 to 2) cannot be missing, it is carried over "
                        "from the input"
                      : "a number (only denoise takes NaN, as a missing value)";
      } else if (root) {
        where += "a root translation within +-" + number_text(kMaxRootTranslationMm) + " mm a frame";
      } else {
        where += "an exponential-map value within +-" + number_text(kMaxRotationRadians) + " radians";
      }
      throw InputError(where);
    }
  }
}

void TakeProcessor::State::take_input(const float* values, int64_t frames) {
  MotionFrames step;
  step.columns = columns;
  step.values.assign(values, values + frames * columns);
  if (denoises() && (options.denoise.zeros_are_missing || options.denoise.means_are_missing)) {
    // What the options call missing becomes NaN here, at the input's rate:
    // resampling moves values off an exact zero or mean, but keeps a NaN.
    const auto& normalization = model.normalization();
    for (int64_t f = 0; f < frames; ++f) {
      float* frame = step.frame(f);
      for (int c : normalization.kept_columns) {
        const float missing_value = options.denoise.zeros_are_missing ? 0.0f : normalization.mean[c];
        if (frame[c] == missing_value) frame[c] = std::numeric_limits<float>::quiet_NaN();
      }
    }
  }
  if (answers() && !reference_at_model_rate()) reference.append(step.values.data(), frames);
  input_frames += frames;
  MotionFrames at_model_rate;
  at_model_rate.columns = columns;
  to_model.push(step.values.data(), frames, at_model_rate);
  take_model_frames(at_model_rate);
}

void TakeProcessor::State::take_model_frames(const MotionFrames& frames) {
  if (answers() && reference_at_model_rate()) reference.append(frames.values.data(), frames.frame_count());
  if (gap_fitter) gap_fitter->observe(frames);
  model_frames.append(frames.values.data(), frames.frame_count());
  while (next_start + windowing.window_frames <= model_frames.end()) {
    ready_starts.push_back(next_start);
    last_queued_start = next_start;
    next_start += windowing.hop_frames;
  }
  note_held();
  run_ready_windows(static_cast<size_t>(options.batch_windows));
}

void TakeProcessor::State::run_ready_windows(size_t at_least) {
  const auto batch = static_cast<size_t>(options.batch_windows);
  while (!ready_starts.empty() && ready_starts.size() >= std::min(at_least, batch)) {
    const size_t count = std::min(batch, ready_starts.size());
    std::vector<int64_t> starts(ready_starts.begin(), ready_starts.begin() + static_cast<std::ptrdiff_t>(count));
    ready_starts.erase(ready_starts.begin(), ready_starts.begin() + static_cast<std::ptrdiff_t>(count));
    run_batch(starts);
  }
}

void TakeProcessor::State::run_batch(const std::vector<int64_t>& starts) {
  const int64_t count = static_cast<int64_t>(starts.size()), window = windowing.window_frames;
  std::vector<float> raw_windows(static_cast<size_t>(count * window * columns));
  for (int64_t i = 0; i < count; ++i) {
    std::memcpy(raw_windows.data() + i * window * columns, model_frames.frame(starts[i]),
                sizeof(float) * window * columns);
  }
  note_held(count * window);
  std::vector<float> codes, decoded;
  int64_t latent = 0;
  run_tensor_work(run, [&] {
    c10::InferenceMode inference;
    auto raw = at::from_blob(raw_windows.data(), {count, window, columns}).to(model.device());
    auto normalized = model.to_normalized(raw);
    at::Tensor code, output;
    if (!answers()) {
      code = model.encode(normalized);
    } else if (!denoises()) {
      code = model.encode(normalized);
      output = model.decode(code, options.decoder);
    } else {
      // NaN marks what is missing: the input's gaps, and what the options
      // call missing (made NaN as it came in).
      auto missing = at::isnan(normalized);
      if (!missing.any().item<bool>()) missing = at::Tensor();
      output = project_onto_manifold(model, normalized, missing, options.decoder, options.denoise.iterations, &code);
    }
    code = code.to(at::kFloat).cpu().contiguous();
    latent = code.size(1);
    codes.assign(code.data_ptr<float>(), code.data_ptr<float>() + code.numel());
    if (output.defined()) {
      auto out = model.to_raw(output).to(at::kFloat).cpu().contiguous();
      decoded.assign(out.data_ptr<float>(), out.data_ptr<float>() + out.numel());
      if (options.root == TakeRoot::kGenerated) write_generated_root_changes(model, output, code, decoded.data(), columns);
    }
  });
  raw_windows = {};

  MotionFrames final_frames, window_frames;
  final_frames.columns = window_frames.columns = columns;
  for (int64_t i = 0; i < count; ++i) {
    TakeWindowCode code;
    code.start_frame = starts[i];
    code.start_seconds = static_cast<double>(starts[i]) / kTakeModelRate;
    code.code.assign(codes.begin() + i * latent, codes.begin() + (i + 1) * latent);
    if (sink.on_window) sink.on_window(code);
    ++windows;
    if (answers()) {
      const auto* first = decoded.data() + i * window * columns;
      window_frames.values.assign(first, first + window * columns);
      assembler.add(starts[i], window_frames, final_frames);
    }
  }
  // Every later window starts after this batch's last.
  model_frames.drop_before(starts.back() + 1);
  if (answers()) hand_out_assembled(final_frames, false);
}

void TakeProcessor::State::hand_out_assembled(const MotionFrames& assembled, bool last) {
  assembled_out += assembled.frame_count();
  // The fitted fill's frames replace the assembled ones around each gap
  // (at 25 Hz, as the model's clips are) before they go to the output rate.
  MotionFrames fitted;
  if (gap_fitter) {
    fitted.columns = columns;
    gap_fitter->push(assembled, last, fitted);
  }
  const MotionFrames& final_frames = gap_fitter ? fitted : assembled;
  MotionFrames output;
  output.columns = columns;
  if (!to_output) {
    output = final_frames;
  } else {
    to_output->push(final_frames.values.data(), final_frames.frame_count(), output);
    // The reply is exactly as long as the input: the 25 Hz frames end at or
    // before the input's last frame's time, and the last pose is held.
    if (last) to_output->finish(output, input_frames);
  }
  // The batch's final frames, their reply and its copy for the error.
  note_held(final_frames.frame_count() + 2 * output.frame_count() +
            (gap_filler ? 2 * gap_filler->held_frames() : 0) + (gap_fitter ? gap_fitter->held_frames() : 0));
  answer(output, last);
}

void TakeProcessor::State::answer(MotionFrames& output, bool last) {
  const int64_t count = std::min(output.frame_count(), reference.end() - output_frames);
  if (count <= 0 && !(last && gap_filler)) return;
  output.values.resize(static_cast<size_t>(std::max<int64_t>(count, 0) * columns));
  for (int64_t f = 0; f < count; ++f) {
    if (options.root == TakeRoot::kInput) {
      std::memcpy(output.frame(f), reference.frame(output_frames + f), kRootTranslationValues * sizeof(float));
    }
  }
  // The reference with its missing values taken from the output: the error
  // counts only observed rotations.
  MotionFrames filled;
  if (gap_filler) {
    // keep_observed: the observed values as given, each gap filled to meet
    // them (take_gap_filler.h); frames of a gap still open wait for it to close.
    MotionFrames given, final_frames;
    given.columns = final_frames.columns = columns;
    if (count > 0) given.values.assign(reference.frame(output_frames), reference.frame(output_frames) + count * columns);
    gap_filler->push(given, output, final_frames);
    if (last) gap_filler->finish(final_frames);
    output = std::move(final_frames);
    filled = output;
  } else {
    filled = output;
    for (int64_t f = 0; f < count; ++f) {
      const float* given = reference.frame(output_frames + f);
      float* ref = filled.frame(f);
      for (int c = 0; c < columns; ++c) {
        if (!std::isnan(given[c])) ref[c] = given[c];
      }
    }
  }
  output_frames += std::max<int64_t>(count, 0);
  reference.drop_before(output_frames);
  if (output.frame_count() == 0) return;
  const auto errors = frame_errors_mm(model, output, filled, run);
  for (float e : errors) {
    error_sum += e;
    error_max = std::max(error_max, static_cast<double>(e));
  }
  if (options.root == TakeRoot::kGenerated) {
    const double rate = options.at_model_rate ? kTakeModelRate : options.frame_rate;
    if (!root_path) root_path.emplace(kRootRotationStepsPerFrame * kTakeModelRate / rate, trajectory_frame_of(model.skeleton()));
    if (!floor) floor.emplace(model.skeleton(), static_cast<int>(std::lround(2 * rate)));
    root_path->integrate(output);
    floor->settle(output);
  }
  if (sink.on_frames) sink.on_frames(output, errors);
}

TakeProcessor::TakeProcessor(const MotionManifold& model, TakeOptions options, TakeSink sink, TorchRunner run) {
  check_take_rate(options.frame_rate, "frame_rate");
  check_common_options(model, options.decoder, options.operation != TakeOperation::kEncode, options.batch_windows,
                       options.max_seconds, options.max_seconds_name);
  if (options.operation == TakeOperation::kDenoise) {
    const auto& d = options.denoise;
    if (d.iterations < 1) throw InputError("iterations", "expected at least 1, found " + std::to_string(d.iterations));
    if (d.zeros_are_missing && d.means_are_missing) {
      throw InputError("means_are_missing", "expected either zeros_are_missing or means_are_missing, found both");
    }
    const auto& fit = options.gap_fit;
    if (fit.iterations < 0 || fit.max_windows < 0 || fit.encoder_rounds < 1 || !(fit.learning_rate > 0) ||
        !std::isfinite(fit.learning_rate) || !(fit.prior_weight >= 0) || !std::isfinite(fit.prior_weight) ||
        !(fit.min_seconds >= 0) || !std::isfinite(fit.min_seconds)) {
      throw InputError("gap_fit", "expected iterations and max_windows of 0 or more, encoder_rounds of at least 1, a "
                       "positive finite learning_rate and finite prior_weight and min_seconds of 0 or more");
    }
  }
  if (options.root == TakeRoot::kGenerated && !model.has_trajectory()) {
    throw InputError("root", "\"generated\" needs a model with a trajectory network, which this model lacks; expected "
                     "\"input\"");
  }
  state_ = std::make_unique<State>(model, std::move(options), std::move(sink), std::move(run));
}

TakeProcessor::~TakeProcessor() = default;

int TakeProcessor::columns() const { return state_->columns; }

int64_t TakeProcessor::held_frames_peak() const { return state_->held_peak; }

void TakeProcessor::push(const float* values, int64_t frames) {
  State& s = *state_;
  if (s.finished) throw std::logic_error("TakeProcessor::push after finish");
  if (frames <= 0) return;
  const double rate = s.options.frame_rate;
  if (s.options.max_seconds > 0 && (s.input_frames + frames - 1) / rate > s.options.max_seconds) {
    throw InputError("take", "longer than " + s.options.max_seconds_name + " (" + number_text(s.options.max_seconds) +
                     " s): frame " + std::to_string(s.input_frames + frames - 1) + " at " + number_text(rate) +
                     " Hz lies at " + number_text((s.input_frames + frames - 1) / rate) + " s");
  }
  s.check_values(values, frames);
  for (int64_t done = 0; done < frames; done += kPushStepFrames) {
    s.take_input(values + done * s.columns, std::min(kPushStepFrames, frames - done));
  }
}

TakeSummary TakeProcessor::finish() {
  State& s = *state_;
  if (s.finished) throw std::logic_error("TakeProcessor::finish called twice");
  s.finished = true;
  const double rate = s.options.frame_rate;
  const int64_t minimum = minimum_take_frames(s.windowing, rate);
  if (s.input_frames < minimum) {
    // A duration is frames over rate: 150 frames at 25 Hz are a 6 s window.
    throw InputError("take", std::to_string(s.input_frames) + " frames at " + number_text(rate) + " Hz (" +
                     number_text(s.input_frames / rate) + " s) is shorter than one window of the model (" +
                     number_text(s.windowing.window_frames / kTakeModelRate) + " s); expected at least " +
                     std::to_string(minimum) + " frames at " + number_text(rate) + " Hz");
  }
  MotionFrames last_frames;
  last_frames.columns = s.columns;
  s.to_model.finish(last_frames);
  s.take_model_frames(last_frames);
  // The regular windows are all queued; the last one, aligned to the take's
  // end, is known only now.
  for (int64_t start : take_window_starts(s.to_model.output_frames(), s.windowing, rate)) {
    if (start > s.last_queued_start) {
      s.ready_starts.push_back(start);
      s.last_queued_start = start;
    }
  }
  s.run_ready_windows(1);
  if (s.answers()) {
    MotionFrames final_frames;
    final_frames.columns = s.columns;
    s.assembler.finish(final_frames);
    s.hand_out_assembled(final_frames, true);
  }

  TakeSummary summary;
  summary.input_frames = s.input_frames;
  summary.input_rate = rate;
  summary.model_frames = s.to_model.output_frames();
  summary.output_frames = s.output_frames;
  summary.output_rate = s.options.at_model_rate ? kTakeModelRate : rate;
  summary.windows = s.windows;
  summary.window_seconds = s.windowing.window_frames / kTakeModelRate;
  summary.hop_seconds = s.windowing.hop_frames / kTakeModelRate;
  summary.mean_error_mm = s.output_frames > 0 ? s.error_sum / static_cast<double>(s.output_frames) : 0.0;
  summary.max_error_mm = s.error_max;
  if (s.gap_fitter) {
    summary.gap_windows_fitted = s.gap_fitter->counts().windows_fitted;
    summary.gaps_fitted = s.gap_fitter->counts().gaps_fitted;
    summary.gaps_over_fit_limit = s.gap_fitter->counts().gaps_over_limit;
  }
  return summary;
}

TakeResult process_take(const MotionManifold& model, const MotionFrames& take, const TakeOptions& options,
                        TorchRunner run) {
  const int columns = model.normalization().input_columns();
  if (take.columns != columns) {
    throw InputError("take", "expected " + std::to_string(columns) + " values per frame, found " +
                     std::to_string(take.columns));
  }
  TakeResult result;
  result.frames.columns = columns;
  TakeSink sink;
  sink.on_window = [&result](const TakeWindowCode& window) { result.windows.push_back(window); };
  sink.on_frames = [&result](const MotionFrames& frames, const std::vector<float>& error_mm) {
    result.frames.values.insert(result.frames.values.end(), frames.values.begin(), frames.values.end());
    result.error_mm.insert(result.error_mm.end(), error_mm.begin(), error_mm.end());
  };
  TakeProcessor processor(model, options, std::move(sink), std::move(run));
  processor.push(take.values.data(), take.frame_count());
  result.summary = processor.finish();
  return result;
}

TakeSummary decode_code_track(const MotionManifold& model, const std::vector<TakeWindowCode>& track,
                              const CodeTrackDecoding& options, const TakeSink& sink, TorchRunner run) {
  check_take_rate(options.frame_rate, "frame_rate");
  check_common_options(model, options.decoder, true, options.batch_windows, options.max_seconds,
                       options.max_seconds_name);
  const int columns = model.normalization().input_columns();
  const int64_t window = model.config().frames, latent = model.config().latent;
  if (track.empty()) throw InputError("windows", "expected at least one window (a code track as encode gives)");
  std::vector<int64_t> starts;
  for (size_t i = 0; i < track.size(); ++i) {
    const std::string name = "windows[" + std::to_string(i) + "]";
    const double seconds = track[i].start_seconds;
    const double frame = std::isfinite(seconds) ? std::round(seconds * kTakeModelRate) : -1.0;
    if (i == 0 ? frame != 0 : !(frame >= static_cast<double>(starts.back()))) {
      throw InputError(name + ".start_seconds", "expected " +
                       (i == 0 ? std::string("0 (the track's start)")
                               : "at or after windows[" + std::to_string(i - 1) + "]'s " +
                                     number_text(starts.back() / kTakeModelRate) + " s (windows in order of start)") +
                       ", found " + number_text(seconds));
    }
    if (i > 0 && frame > static_cast<double>(starts.back() + window)) {
      throw InputError(name + ".start_seconds", "expected at most " +
                       number_text((starts.back() + window) / kTakeModelRate) + " s (where windows[" +
                       std::to_string(i - 1) + "] ends: a later start leaves frames uncovered), found " +
                       number_text(seconds));
    }
    starts.push_back(static_cast<int64_t>(frame));
    const auto& code = track[i].code;
    if (static_cast<int64_t>(code.size()) != latent) {
      throw InputError(name + ".code", "expected " + std::to_string(latent) + " numbers, found " +
                       std::to_string(code.size()));
    }
    for (size_t k = 0; k < code.size(); ++k) {
      if (!std::isfinite(code[k])) {
        throw InputError(name + ".code[" + std::to_string(k) + "]", "expected a finite number, found " +
                         number_text(code[k]));
      }
    }
  }
  const int64_t model_frames = starts.back() + window;
  const int64_t natural = resampled_frame_count(model_frames, kTakeModelRate, options.frame_rate);
  if (options.frames < -1) {
    throw InputError("frames", "expected -1 or 0 (the track's length) or a number of frames, found " +
                     std::to_string(options.frames));
  }
  const int64_t output_frames = options.frames > 0 ? options.frames : natural;
  if (options.max_seconds > 0) {
    const double track_seconds = (model_frames - 1) / kTakeModelRate;
    const double output_seconds = (output_frames - 1) / options.frame_rate;
    if (track_seconds > options.max_seconds || output_seconds > options.max_seconds) {
      const bool track_longer = track_seconds > options.max_seconds;
      throw InputError(track_longer ? "windows" : "frames",
                       number_text(track_longer ? track_seconds : output_seconds) + " s is longer than " +
                       options.max_seconds_name + " (" + number_text(options.max_seconds) + " s)");
    }
  }

  TakeAssembler assembler(columns, options.blend);
  MotionResampler to_output(columns, kTakeModelRate, options.frame_rate);
  int64_t emitted = 0;
  RootPathIntegrator root_path(kRootRotationStepsPerFrame * kTakeModelRate / options.frame_rate,
                               trajectory_frame_of(model.skeleton()));
  StreamingFloor floor(model.skeleton(), static_cast<int>(std::lround(2 * options.frame_rate)));
  auto hand_out = [&](MotionFrames& frames) {
    const int64_t count = std::min(frames.frame_count(), output_frames - emitted);
    if (count <= 0) return;
    frames.values.resize(static_cast<size_t>(count * columns));
    emitted += count;
    if (model.has_trajectory()) {
      root_path.integrate(frames);
      floor.settle(frames);
    }
    if (sink.on_frames) sink.on_frames(frames, {});
  };
  const auto batch = static_cast<size_t>(options.batch_windows);
  for (size_t first = 0; first < track.size(); first += batch) {
    const int64_t count = static_cast<int64_t>(std::min(batch, track.size() - first));
    std::vector<float> codes(static_cast<size_t>(count * latent)), decoded;
    for (int64_t i = 0; i < count; ++i) {
      std::copy(track[first + i].code.begin(), track[first + i].code.end(), codes.begin() + i * latent);
    }
    run_tensor_work(run, [&] {
      c10::InferenceMode inference;
      auto code = at::from_blob(codes.data(), {count, latent}).to(model.device());
      auto poses = model.decode(code, options.decoder);
      auto out = model.to_raw(poses).to(at::kFloat).cpu().contiguous();
      decoded.assign(out.data_ptr<float>(), out.data_ptr<float>() + out.numel());
      if (model.has_trajectory()) write_generated_root_changes(model, poses, code, decoded.data(), columns);
    });
    MotionFrames final_frames, window_frames, output;
    final_frames.columns = window_frames.columns = output.columns = columns;
    for (int64_t i = 0; i < count; ++i) {
      const auto* values = decoded.data() + i * window * columns;
      window_frames.values.assign(values, values + window * columns);
      assembler.add(starts[first + i], window_frames, final_frames);
    }
    to_output.push(final_frames.values.data(), final_frames.frame_count(), output);
    hand_out(output);
  }
  MotionFrames final_frames, output;
  final_frames.columns = output.columns = columns;
  assembler.finish(final_frames);
  to_output.push(final_frames.values.data(), final_frames.frame_count(), output);
  to_output.finish(output, std::max(output_frames, to_output.output_frames()));
  hand_out(output);

  TakeSummary summary;
  summary.model_frames = model_frames;
  summary.output_frames = emitted;
  summary.output_rate = options.frame_rate;
  summary.windows = static_cast<int>(track.size());
  summary.window_seconds = window / kTakeModelRate;
  return summary;
}

const char* take_root_name(TakeRoot root) { return root == TakeRoot::kInput ? "input" : "generated"; }

TakeRoot parse_take_root(const std::string& name, const std::string& field) {
  if (name == "input") return TakeRoot::kInput;
  if (name == "generated") return TakeRoot::kGenerated;
  throw InputError(field, "expected \"input\" or \"generated\", found \"" + name + "\"");
}

}  // namespace mm
