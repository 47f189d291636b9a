#include "model/gap_code_fit.h"

#include <c10/core/InferenceMode.h>
#include <torch/csrc/autograd/autograd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "format/input_error.h"
#include "model/gap_interpolation.h"
#include "model/gru_recurrence.h"
#include "model/latent_operations.h"
#include "model/take_windows.h"

namespace mm {
namespace {

// The decoder as a differentiable function of the code (Eq. 2-3 / 5-6 by
// gru_autoregressive, as DecoderImpl::forward), over copies of its weights
// that require no gradient: a model loaded in inference mode holds
// inference tensors, which a backward pass cannot save.
class DifferentiableDecoder {
 public:
  explicit DifferentiableDecoder(const DecoderImpl& decoder) : shape_(decoder.shape()) {
    const auto parameters = decoder.named_parameters();
    auto copy = [&](const char* name) { return parameters[name].detach().to(at::kFloat).clone(); };
    from_code_weight_ = copy("from_code.weight");
    from_code_bias_ = copy("from_code.bias");
    weights_.gru = GruWeights{copy("cell.weight_ih").unsqueeze(0), copy("cell.bias_ih").unsqueeze(0),
                              copy("cell.weight_hh").unsqueeze(0), copy("cell.bias_hh").unsqueeze(0)};
    weights_.weight_out = copy("to_pose.weight").unsqueeze(0);
    weights_.bias_out = copy("to_pose.bias").unsqueeze(0);
    weights_.residual = {shape_.residual};
  }
  // z (B, latent) to poses (B, frames, D) in time order.
  at::Tensor operator()(const at::Tensor& z) const {
    const auto h0 = at::addmm(from_code_bias_, z, from_code_weight_.t()).unsqueeze(0);
    const auto generated = gru_autoregressive(h0, z, weights_, shape_.frames, shape_.feed_code);  // (1, T, B, D)
    return generated[0].flip(0).transpose(0, 1);  // generated last frame first
  }

 private:
  DecoderShape shape_;
  at::Tensor from_code_weight_, from_code_bias_;
  AutoregressiveWeights weights_;
};

}  // namespace

bool gap_length_is_fitted(const FrameSpan& span, int64_t window, const GapCodeFitOptions& options) {
  const int64_t context = static_cast<int64_t>(2 * kTakeModelRate);
  return span.length() <= window - context && static_cast<double>(span.length()) >= options.min_seconds * kTakeModelRate;
}

bool gap_gets_fitted(const MotionFrames& observed, int64_t observed_first, const FrameSpan& span, int64_t window,
                     const GapCodeFitOptions& options) {
  if (!gap_length_is_fitted(span, window, options)) return false;
  // The frames the joints' gaps in the span and their lone-keyframe test
  // read (two either side), from the motion's start on or up to its end
  // where it is nearer: within them the joints' gaps are the motion's.
  const int64_t from = std::max(span.first - 2, observed_first);
  const int64_t to = std::min(span.last + 3, observed_first + observed.frame_count());
  MotionFrames around;
  around.columns = observed.columns;
  around.values.assign(observed.frame(from - observed_first), observed.frame(from - observed_first) +
                                                                   static_cast<size_t>((to - from) * observed.columns));
  for (const JointGap& gap : find_joint_gaps(around)) {
    // The span's first - 1 and last + 1 are observed in every joint: a
    // joint's gap there lies within it or outside it.
    if (gap.first + from < span.first || gap.last + from > span.last) continue;
    if (!gap_borders_lone_keyframe(around, gap)) return true;
  }
  return false;
}

bool gap_joins_window(const GapFitWindow& fit, const FrameSpan& span, int64_t window) {
  const int64_t context = static_cast<int64_t>(2 * kTakeModelRate);
  return !fit.spans.empty() && span.last - fit.spans.front().first + 1 <= window - context;
}

bool window_lays_detail(const GapFitWindow& fit, const float* window_values, int columns,
                        const GapCodeFitOptions& options) {
  if (fit.observed_error <= options.max_observed_error) return true;
  for (const FrameSpan& span : fit.spans) {
    const int64_t middle = (span.first + span.last) / 2 - fit.start;
    if (most_joints_missing(window_values + middle * columns, columns)) return false;
  }
  return true;
}

int64_t centred_window_start(const GapFitWindow& fit, int64_t frames, int64_t window) {
  const int64_t first = fit.spans.front().first, last = fit.spans.back().last;
  return std::clamp<int64_t>((first + last + 1) / 2 - window / 2, 0, frames - window);
}

std::vector<std::vector<float>> fit_window_clips(const MotionManifold& model, const std::vector<const float*>& windows,
                                                 DecoderKind kind, const GapCodeFitOptions& options,
                                                 std::vector<double>* observed_errors) {
  if (windows.empty()) return {};
  const int64_t window = model.config().frames, columns = model.normalization().input_columns();
  const auto batch = static_cast<int64_t>(windows.size());
  auto raw = at::empty({batch, window, columns});
  for (int64_t b = 0; b < batch; ++b) {
    std::memcpy(raw[b].data_ptr<float>(), windows[static_cast<size_t>(b)],
                sizeof(float) * static_cast<size_t>(window * columns));
  }
  at::Tensor normalized, missing, code;
  {
    c10::InferenceMode inference;
    normalized = model.to_normalized(raw.to(model.device()));
    missing = at::isnan(normalized);
    project_onto_manifold(model, normalized, missing, kind, options.encoder_rounds, &code);
  }
  at::Tensor fitted;
  {
    // The fit differentiates through the decoder: out of inference mode,
    // with tensors made outside it (inference tensors cannot be saved for
    // a backward pass).
    c10::InferenceMode not_inference(false);
    at::AutoGradMode gradients(true);
    const auto target = normalized.clone().masked_fill(missing, 0.0);
    const auto seen = missing.logical_not().to(at::kFloat);
    const auto seen_count = seen.sum({1, 2}).clamp_min(1.0);  // (B)
    auto z = code.clone().detach().to(at::kFloat).requires_grad_(true);
    auto first_moment = at::zeros_like(z), second_moment = at::zeros_like(z);
    const DifferentiableDecoder decoder(*model.decoder(kind));
    constexpr double kBeta1 = 0.9, kBeta2 = 0.999, kEpsilon = 1e-8;
    for (int step = 1; step <= options.iterations; ++step) {
      const auto poses = decoder(z);
      // Each clip's loss on its own (summed over the batch, so that its
      // gradient is its own code's).
      const auto error = ((poses - target) * seen).pow(2).sum({1, 2}) / seen_count;
      const auto loss = (error + options.prior_weight * z.pow(2).mean(1)).sum();
      const auto gradient = torch::autograd::grad({loss}, {z})[0];
      at::NoGradGuard no_gradients;
      first_moment.mul_(kBeta1).add_(gradient, 1 - kBeta1);
      second_moment.mul_(kBeta2).addcmul_(gradient, gradient, 1 - kBeta2);
      const double step_size = options.learning_rate * std::sqrt(1 - std::pow(kBeta2, step)) / (1 - std::pow(kBeta1, step));
      z.addcdiv_(first_moment, second_moment.sqrt().add_(kEpsilon), -step_size);
    }
    fitted = z.detach();
  }
  at::Tensor clips;
  {
    c10::InferenceMode inference;
    const auto poses = model.decode(fitted.to(code.scalar_type()), kind);
    if (observed_errors) {
      const auto seen = missing.logical_not().to(at::kFloat);
      const auto error = ((poses.to(at::kFloat) - normalized.to(at::kFloat).masked_fill(missing, 0.0)) * seen)
                             .pow(2).sum({1, 2}) / seen.sum({1, 2}).clamp_min(1.0);
      const auto values = error.cpu().contiguous();
      observed_errors->assign(values.data_ptr<float>(), values.data_ptr<float>() + batch);
    }
    clips = model.to_raw(poses).to(at::kFloat).cpu().contiguous();
  }
  std::vector<std::vector<float>> out(static_cast<size_t>(batch));
  for (int64_t b = 0; b < batch; ++b) {
    const float* clip = clips[b].data_ptr<float>();
    out[static_cast<size_t>(b)].assign(clip, clip + window * columns);
  }
  return out;
}

void write_fitted_window(const GapFitWindow& fit, const float* clip, int64_t window, bool gap_frames,
                         MotionFrames& out, int64_t out_first, std::vector<bool>& written) {
  const int64_t columns = out.columns;
  for (const FrameSpan& span : fit.spans) {
    const int64_t from = gap_frames ? span.first : std::max(fit.start, span.first - 2);
    const int64_t to = gap_frames ? span.last : std::min(fit.start + window - 1, span.last + 2);
    for (int64_t f = from; f <= to; ++f) {
      const auto at = static_cast<size_t>(f - out_first);
      if (!gap_frames && written[at]) continue;
      if (gap_frames) written[at] = true;
      float* values = out.frame(f - out_first) + kRootTranslationValues;
      if (gap_frames && !fit.lays_detail) {
        std::fill_n(values, columns - kRootTranslationValues, std::numeric_limits<float>::quiet_NaN());
        continue;
      }
      std::memcpy(values, clip + (f - fit.start) * columns + kRootTranslationValues,
                  sizeof(float) * static_cast<size_t>(columns - kRootTranslationValues));
    }
  }
}

MotionFrames fit_gap_codes(const MotionManifold& model, const MotionFrames& observed, const MotionFrames& decoded,
                           DecoderKind kind, const GapCodeFitOptions& options, GapFitCounts* counts,
                           std::vector<GapFitWindow>* fitted_windows) {
  if (decoded.columns != observed.columns || decoded.frame_count() != observed.frame_count()) {
    throw InputError("decoded", "expected the observed motion's shape");
  }
  MotionFrames result = decoded;
  GapFitCounts counted;
  const int64_t window = model.config().frames, frames = observed.frame_count();
  if (frames < window) {
    if (counts) *counts = counted;
    return result;
  }
  std::vector<GapFitWindow> fits;
  for (const FrameSpan& span : find_missing_spans(observed)) {
    if (!gap_gets_fitted(observed, 0, span, window, options)) continue;
    if (fits.empty() || !gap_joins_window(fits.back(), span, window)) fits.emplace_back();
    fits.back().spans.push_back(span);
  }
  if (options.max_windows > 0 && static_cast<int64_t>(fits.size()) > options.max_windows) {
    for (size_t i = static_cast<size_t>(options.max_windows); i < fits.size(); ++i) {
      counted.gaps_over_limit += static_cast<int>(fits[i].spans.size());
    }
    fits.resize(static_cast<size_t>(options.max_windows));
  }
  std::vector<const float*> windows;
  for (GapFitWindow& fit : fits) {
    fit.start = centred_window_start(fit, frames, window);
    windows.push_back(observed.frame(fit.start));
    ++counted.windows_fitted;
    counted.gaps_fitted += static_cast<int>(fit.spans.size());
  }
  if (counts) *counts = counted;
  if (fitted_windows) fitted_windows->clear();
  if (fits.empty()) return result;
  std::vector<double> errors;
  const auto clips = fit_window_clips(model, windows, kind, options, &errors);
  for (size_t b = 0; b < fits.size(); ++b) {
    fits[b].observed_error = errors[b];
    fits[b].lays_detail = window_lays_detail(fits[b], windows[b], observed.columns, options);
  }
  if (fitted_windows) *fitted_windows = fits;
  std::vector<bool> written(static_cast<size_t>(frames), false);
  for (const bool gap_frames : {false, true}) {
    for (size_t b = 0; b < fits.size(); ++b) {
      write_fitted_window(fits[b], clips[b].data(), window, gap_frames, result, 0, written);
    }
  }
  return result;
}

}  // namespace mm
