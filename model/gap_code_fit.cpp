#include "gap_code_fit.h"

#include <c10/core/InferenceMode.h>
#include <torch/csrc/autograd/autograd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "format/input_error.h"
#include "gru_recurrence.h"
#include "latent_operations.h"
#include "take_windows.h"

namespace mm {
namespace {

// Runs of frames where any joint value is missing (NaN), first..last inclusive.
std::vector<std::pair<int64_t, int64_t>> missing_spans(const MotionFrames& motion) {
  std::vector<std::pair<int64_t, int64_t>> spans;
  int64_t start = -1;
  for (int64_t f = 0; f <= motion.frame_count(); ++f) {
    bool missing = false;
    if (f < motion.frame_count()) {
      const float* v = motion.frame(f);
      for (int c = kRootTranslationValues; c < motion.columns && !missing; ++c) missing = std::isnan(v[c]);
    }
    if (missing && start < 0) start = f;
    if (!missing && start >= 0) {
      spans.emplace_back(start, f - 1);
      start = -1;
    }
  }
  return spans;
}

// The decoder as a differentiable function of the code (Eq. 2-3 / 5-6 by
// gru_autoregressive, as DecoderImpl::forward), over copies of its weights
// that require no gradient: a model loaded in inference mode holds
// inference tensors, which a backward pass cannot save.
class DifferentiableDecoder {
 public:
  explicit DifferentiableDecoder(const DecoderImpl& decoder) : shape_(decoder.shape()) {
    const auto parameters = decoder.named_parameters();
    auto copy = [&](const char* name) { return parameters[name].detach().clone(); };
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

MotionFrames fit_gap_codes(const MotionManifold& model, const MotionFrames& observed, const MotionFrames& decoded,
                           DecoderKind kind, const GapCodeFitOptions& options) {
  if (decoded.columns != observed.columns || decoded.frame_count() != observed.frame_count()) {
    throw InputError("decoded: expected the observed motion's shape");
  }
  MotionFrames result = decoded;
  const int64_t window = model.config().frames, frames = observed.frame_count();
  const int64_t context = static_cast<int64_t>(2 * kTakeModelRate);
  if (frames < window) return result;
  // Gaps near each other share a window (sparse keyframes make a gap
  // between every two): a window takes gaps while they span at most the
  // clip less `context`, and is centred on them.
  struct Fit {
    std::vector<std::pair<int64_t, int64_t>> spans;
    int64_t start = 0;
  };
  std::vector<Fit> fits;
  for (const auto& span : missing_spans(observed)) {
    const int64_t length = span.second - span.first + 1;
    if (length > window - context || static_cast<double>(length) < options.min_seconds * kTakeModelRate) continue;
    if (fits.empty() || span.second - fits.back().spans.front().first + 1 > window - context) fits.emplace_back();
    fits.back().spans.push_back(span);
  }
  for (Fit& fit : fits) {
    const int64_t first = fit.spans.front().first, last = fit.spans.back().second;
    fit.start = std::clamp<int64_t>((first + last + 1) / 2 - window / 2, 0, frames - window);
  }
  if (fits.empty()) return result;

  const int64_t columns = observed.columns, batch = static_cast<int64_t>(fits.size());
  auto raw = at::empty({batch, window, columns});
  for (int64_t b = 0; b < batch; ++b) {
    std::memcpy(raw[b].data_ptr<float>(), observed.frame(fits[static_cast<size_t>(b)].start),
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
    auto z = code.clone().detach().requires_grad_(true);
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
    clips = model.to_raw(model.decode(fitted, kind)).cpu().contiguous();
  }
  // Each gap's frames and two either side (the matched fill reads the
  // manifold's borders and their velocities); the gaps' own frames last,
  // so that a gap's frames are never another window's border frames.
  for (const bool gap_frames : {false, true}) {
    for (int64_t b = 0; b < batch; ++b) {
      const Fit& fit = fits[static_cast<size_t>(b)];
      const float* clip = clips[b].data_ptr<float>();
      for (const auto& [first, last] : fit.spans) {
        const int64_t from = gap_frames ? first : std::max(fit.start, first - 2);
        const int64_t to = gap_frames ? last : std::min(fit.start + window - 1, last + 2);
        for (int64_t f = from; f <= to; ++f) {
          std::memcpy(result.frame(f) + kRootTranslationValues,
                      clip + (f - fit.start) * columns + kRootTranslationValues,
                      sizeof(float) * static_cast<size_t>(columns - kRootTranslationValues));
        }
      }
    }
  }
  return result;
}

}  // namespace mm
