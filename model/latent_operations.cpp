#include "model/latent_operations.h"

#include <ATen/CPUGeneratorImpl.h>
#include <ATen/Parallel.h>
#include <c10/core/InferenceMode.h>

#include <cmath>
#include <cstring>
#include <random>

#include "format/foot_contacts.h"
#include "format/input_error.h"

namespace mm {
namespace {

void check_motion(const MotionManifold& model, const MotionFrames& m, size_t index) {
  const std::string name = "motions[" + std::to_string(index) + "]";
  if (m.columns != model.normalization().input_columns()) {
    throw InputError(name, "expected " + std::to_string(model.normalization().input_columns()) +
                     " values per frame, found " + std::to_string(m.columns));
  }
  if (m.frame_count() != model.config().frames) {
    throw InputError(name, "expected " + std::to_string(model.config().frames) + " frames at 25 Hz, found " +
                     std::to_string(m.frame_count()));
  }
}

void check_code(const at::Tensor& code, int64_t latent, const char* name) {
  if (code.dim() != 1 || code.size(0) != latent) {
    throw InputError(std::string(name), "expected a code of " + std::to_string(latent) + " values, found shape " +
                     c10::str(code.sizes()));
  }
}

// Raw frames (n, frames, input columns) of checked motions, on the model's device.
at::Tensor stack_motions(const MotionManifold& model, const std::vector<MotionFrames>& motions) {
  if (motions.empty()) throw InputError("motions", "expected at least one motion");
  const int64_t frames = model.config().frames, columns = model.normalization().input_columns();
  auto raw = at::empty({static_cast<int64_t>(motions.size()), frames, columns});
  for (size_t i = 0; i < motions.size(); ++i) {
    check_motion(model, motions[i], i);
    std::memcpy(raw[static_cast<int64_t>(i)].data_ptr<float>(), motions[i].values.data(), sizeof(float) * frames * columns);
  }
  return raw.to(model.device());
}

// Normalised clips (n, frames, D) to raw motions; the root translation of
// `translation_from` (same count) when given, else the model's generated
// root when it has a trajectory network.
std::vector<MotionFrames> to_motions(const MotionManifold& model, const at::Tensor& normalized,
                                     const std::vector<MotionFrames>* translation_from, const at::Tensor& codes) {
  auto raw = model.to_raw(normalized).cpu().contiguous();
  std::vector<MotionFrames> result(static_cast<size_t>(raw.size(0)));
  const int64_t per_motion = raw.size(1) * raw.size(2);
  for (size_t i = 0; i < result.size(); ++i) {
    result[i].columns = static_cast<int>(raw.size(2));
    const float* src = raw.data_ptr<float>() + static_cast<int64_t>(i) * per_motion;
    result[i].values.assign(src, src + per_motion);
    if (translation_from) {
      const auto& source = (*translation_from)[i];
      for (int64_t f = 0; f < result[i].frame_count(); ++f) std::memcpy(result[i].frame(f), source.frame(f), 3 * sizeof(float));
    }
  }
  if (!translation_from && model.has_trajectory()) write_generated_roots(model, normalized, codes, result);
  return result;
}

}  // namespace

at::Tensor encode_motions(const MotionManifold& model, const std::vector<MotionFrames>& motions) {
  c10::InferenceMode inference;
  return model.encode(model.to_normalized(stack_motions(model, motions))).cpu();
}

std::vector<MotionFrames> decode_codes(const MotionManifold& model, const at::Tensor& codes, DecoderKind kind,
                                       const std::vector<MotionFrames>* translation_from) {
  c10::InferenceMode inference;
  const int64_t latent = model.config().latent;
  if (codes.dim() != 2 || codes.size(1) != latent) {
    throw InputError("codes", "expected shape (n, " + std::to_string(latent) + "), found " + c10::str(codes.sizes()));
  }
  if (!at::isfinite(codes).all().item<bool>()) throw InputError("codes", "values must be finite numbers");
  return to_motions(model, model.decode(codes.to(at::kFloat), kind), translation_from, codes);
}

at::Tensor sample_codes(const MotionManifold& model, int n, uint64_t seed, double prior_variance) {
  if (n < 1) throw InputError("count", "expected at least 1, found " + std::to_string(n));
  auto generator = at::detail::createCPUGenerator(seed);
  return at::randn({n, model.config().latent}, generator) * std::sqrt(prior_variance);
}

at::Tensor interpolate_codes(const at::Tensor& a, const at::Tensor& b, int steps, bool spherical) {
  check_code(a, a.numel(), "from");
  check_code(b, a.numel(), "to");
  if (steps < 2) throw InputError("steps", "expected at least 2, found " + std::to_string(steps));
  auto t = at::linspace(0.0, 1.0, steps).unsqueeze(1);
  if (!spherical) return a.unsqueeze(0) * (1 - t) + b.unsqueeze(0) * t;
  const double norm_a = a.norm().item<double>(), norm_b = b.norm().item<double>();
  // A zero code has no direction: the arc is undefined, the line is not.
  if (norm_a < 1e-12 || norm_b < 1e-12) return a.unsqueeze(0) * (1 - t) + b.unsqueeze(0) * t;
  const double cos_angle = std::clamp(a.dot(b).item<double>() / std::max(norm_a * norm_b, 1e-12), -1.0, 1.0);
  const double angle = std::acos(cos_angle);
  if (angle < 1e-6) return a.unsqueeze(0) * (1 - t) + b.unsqueeze(0) * t;  // parallel: slerp is linear
  // Opposite codes are joined by every half great circle, none of them the
  // arc; float codes that nearly are give an angle of pi, and the division
  // by its sine codes of 1e11.
  if (cos_angle < -1.0 + 1e-6) {
    throw InputError("to", "the code points opposite to from's, so no single arc joins them; expected another code, "
                     "or method linear");
  }
  auto unit_a = a / norm_a, unit_b = b / norm_b;
  auto direction = (at::sin((1 - t) * angle) * unit_a + at::sin(t * angle) * unit_b) / std::sin(angle);
  return direction * ((1 - t) * norm_a + t * norm_b);
}

at::Tensor analogy_code(const at::Tensor& a, const at::Tensor& b, const at::Tensor& c) {
  check_code(b, a.numel(), "b");
  check_code(c, a.numel(), "c");
  return a - b + c;
}

std::vector<MotionFrames> denoise_motions(const MotionManifold& model, const std::vector<MotionFrames>& motions,
                                          DecoderKind kind, const DenoiseOptions& options) {
  c10::InferenceMode inference;
  if (options.iterations < 1) {
    throw InputError("iterations", "expected at least 1, found " + std::to_string(options.iterations));
  }
  if (options.keep_observed && !options.zeros_are_missing && !options.means_are_missing) {
    throw InputError("keep_observed", "expected together with zeros_are_missing or means_are_missing (without "
                     "missing values every value is observed, and nothing would be denoised)");
  }
  const auto raw = stack_motions(model, motions);
  const auto missing = missing_values_mask(model, raw, options);
  const auto normalized = model.to_normalized(raw);
  auto projected = project_onto_manifold(model, normalized, missing, kind, options.iterations);
  if (missing.defined() && options.keep_observed) projected = at::where(missing, projected, normalized);
  return to_motions(model, projected, &motions, at::Tensor());
}

at::Tensor project_onto_manifold(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& missing,
                                 DecoderKind kind, int iterations, at::Tensor* codes) {
  c10::InferenceMode inference;
  at::Tensor code;
  if (!missing.defined()) {
    code = model.encode(normalized);
    if (codes) *codes = code;
    return model.decode(code, kind);
  }
  // Fill the gaps with the manifold's own estimate and project again: each
  // round's code sees only observed values and the previous round's fill.
  auto filled = normalized.masked_fill(missing, 0.0);
  at::Tensor decoded;
  for (int round = 0; round < iterations; ++round) {
    code = model.encode(filled);
    decoded = model.decode(code, kind);
    filled = at::where(missing, decoded, normalized);
  }
  if (codes) *codes = code;
  return decoded;
}

at::Tensor missing_values_mask(const MotionManifold& model, const at::Tensor& raw, const DenoiseOptions& options) {
  if (options.zeros_are_missing && options.means_are_missing) {
    throw InputError("means_are_missing", "expected either zeros_are_missing or means_are_missing, found both");
  }
  if (options.means_are_missing) return model.to_normalized(raw) == 0;
  if (!options.zeros_are_missing) return {};
  const auto& kept = model.normalization().kept_columns;
  auto index = at::tensor(std::vector<int64_t>(kept.begin(), kept.end()), at::kLong).to(raw.device());
  return raw.index_select(-1, index) == 0;
}

const char* corruption_name(Corruption corruption) {
  return corruption == Corruption::kReference ? "reference" : "zeroed";
}

Corruption parse_corruption(const std::string& name) {
  if (name == "reference") return Corruption::kReference;
  if (name == "zeroed") return Corruption::kZeroed;
  throw InputError("corruption", "expected reference or zeroed, found '" + name + "'");
}

MotionFrames corrupt_motion(const MotionFrames& motion, const PoseNormalization& normalization, double probability,
                            uint64_t seed, Corruption corruption) {
  if (!(probability >= 0 && probability <= 1)) {
    throw InputError("probability", "expected a value in [0, 1], found " + std::to_string(probability));
  }
  std::mt19937_64 engine(seed);
  std::bernoulli_distribution dropped(probability);
  MotionFrames corrupted = motion;
  for (int64_t f = 0; f < corrupted.frame_count(); ++f) {
    for (int c : normalization.kept_columns) {
      if (dropped(engine)) corrupted.frame(f)[c] = corruption == Corruption::kReference ? normalization.mean[c] : 0.0f;
    }
  }
  return corrupted;
}

void plant_feet_of_each(const Skeleton& skeleton, std::vector<MotionFrames>& motions, double rate_hz) {
  at::parallel_for(0, static_cast<int64_t>(motions.size()), 1, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) plant_feet(skeleton, motions[static_cast<size_t>(i)], rate_hz);
  });
}

}  // namespace mm
