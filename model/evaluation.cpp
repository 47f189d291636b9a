#include "evaluation.h"

#include <c10/core/InferenceMode.h>

#include <nlohmann/json.hpp>
#include <cstring>
#include <map>
#include <random>
#include <set>

#include "clip_sampler.h"
#include "format/input_error.h"
#include "latent_operations.h"
#include "rotation.h"

namespace mm {
namespace {

// (N, T) per-frame errors to the mean of each of `intervals` equal spans.
std::vector<double> per_interval(const at::Tensor& per_frame, int intervals) {
  auto means = per_frame.reshape({per_frame.size(0), intervals, -1}).mean(at::IntArrayRef{0, 2}).to(at::kDouble).contiguous();
  return std::vector<double>(means.data_ptr<double>(), means.data_ptr<double>() + intervals);
}

at::Tensor frame_norm(const at::Tensor& difference, int64_t trailing_dims) {
  return difference.flatten(difference.dim() - trailing_dims, -1).norm(2, -1);
}

// Mean per-joint position error in mm, over clips, frames and joints.
double mean_joint_error_mm(const at::Tensor& positions, const at::Tensor& truth) {
  return (positions - truth).norm(2, -1).mean().item<double>();
}

// A baseline without the manifold: each missing value (B, T, D) linearly
// interpolated in time between the nearest frames where it was observed,
// held constant before the first and after the last, the training mean where
// never observed.
at::Tensor interpolate_missing_in_time(const at::Tensor& normalized, const at::Tensor& missing) {
  auto filled = normalized.cpu().masked_fill(missing.cpu(), 0.0).contiguous();
  auto known = missing.cpu().logical_not().contiguous();
  const int64_t clips = filled.size(0), frames = filled.size(1), dims = filled.size(2);
  float* v = filled.data_ptr<float>();
  const bool* observed = known.data_ptr<bool>();
  for (int64_t n = 0; n < clips; ++n) {
    for (int64_t d = 0; d < dims; ++d) {
      auto at_frame = [&](int64_t t) -> int64_t { return (n * frames + t) * dims + d; };
      int64_t previous = -1;
      for (int64_t t = 0; t <= frames; ++t) {
        if (t < frames && !observed[at_frame(t)]) continue;
        if (previous < 0 && t == frames) break;  // never observed: keep the mean
        for (int64_t gap = previous + 1; gap < t; ++gap) {
          const float before = v[at_frame(previous < 0 ? t : previous)];
          const float after = v[at_frame(t < frames ? t : previous)];
          const float w = previous < 0 || t == frames ? 0.0f : static_cast<float>(gap - previous) / (t - previous);
          v[at_frame(gap)] = before + w * (after - before);
        }
        previous = t;
      }
    }
  }
  return filled.to(normalized.device());
}

// The errors in mm against the truth of raw corrupted clips (N, T, C) whose
// dropped values are zero: as they are, projected as they are (the paper),
// projected with the zeros as missing, the same keeping the observed values,
// and interpolated in time.
nlohmann::json missing_value_errors(const MotionManifold& model, const at::Tensor& corrupted, const at::Tensor& truth_mm) {
  const auto kind = model.default_decoder();
  const auto on_device = corrupted.to(model.device());
  const auto normalized = model.to_normalized(on_device);
  const auto missing = zero_values_mask(model, on_device);
  const int rounds = DenoiseOptions{}.iterations;
  const auto filled = project_onto_manifold(model, normalized, missing, kind, rounds);
  auto error_mm = [&](const at::Tensor& n) { return mean_joint_error_mm(model.positions_mm(n), truth_mm); };
  return {{"decoder", decoder_name(kind)},
          {"missing_fraction", missing.to(at::kFloat).mean().item<double>()},
          {"corrupted_mpjpe_mm", error_mm(normalized)},
          {"denoised_mpjpe_mm", error_mm(project_onto_manifold(model, normalized, {}, kind, 1))},
          {"zeros_missing_iterations", rounds},
          {"denoised_zeros_missing_mpjpe_mm", error_mm(filled)},
          {"filled_zeros_missing_mpjpe_mm", error_mm(at::where(missing, filled, normalized))},
          {"time_interpolation_mpjpe_mm", error_mm(interpolate_missing_in_time(normalized, missing))}};
}

// Missing markers rather than noise: each joint's values zeroed together over
// one window of `window` frames (uniform start) with the given probability.
// The same seed serves every window length.
at::Tensor zero_joint_windows(const at::Tensor& raw, const PoseNormalization& normalization, int64_t window,
                              double probability, uint64_t seed) {
  auto corrupted = raw.clone();
  std::mt19937_64 engine(seed);
  std::bernoulli_distribution dropped(probability);
  std::uniform_int_distribution<int64_t> start(0, raw.size(1) - window);
  std::map<int, std::vector<int64_t>> columns_of_joint;
  for (int c : normalization.kept_columns) {
    if (c >= 3) columns_of_joint[(c - 3) / 3].push_back(c);  // not root translation
  }
  for (int64_t i = 0; i < raw.size(0); ++i) {
    for (const auto& [joint, columns] : columns_of_joint) {
      if (!dropped(engine)) continue;
      const int64_t first = start(engine);
      for (int64_t c : columns) corrupted[i].select(1, c).narrow(0, first, window).zero_();
    }
  }
  return corrupted;
}

nlohmann::json evaluate_denoising(const MotionManifold& model, const at::Tensor& motion, const at::Tensor& truth_mm,
                                  const EvaluationOptions& options) {
  auto raw = model.to_raw(motion).cpu().contiguous();
  const int64_t clips = raw.size(0), frames = raw.size(1), columns = raw.size(2);
  auto corrupted = at::empty_like(raw);
  for (int64_t i = 0; i < clips; ++i) {
    MotionFrames clip;
    clip.columns = static_cast<int>(columns);
    clip.values.assign(raw[i].data_ptr<float>(), raw[i].data_ptr<float>() + frames * columns);
    const auto noisy = corrupt_motion(clip, model.normalization(), options.corruption_probability,
                                      options.corruption_seed + static_cast<uint64_t>(i));
    std::memcpy(corrupted[i].data_ptr<float>(), noisy.values.data(), sizeof(float) * frames * columns);
  }
  auto result = missing_value_errors(model, corrupted, truth_mm);
  result["probability"] = options.corruption_probability;
  result["seed"] = options.corruption_seed;
  // The same with whole joints missing over 1.2 s and over the whole clip.
  result["joint_windows"] = nlohmann::json::array();
  for (int64_t window : {frames / 5, frames}) {
    auto errors = missing_value_errors(
        model, zero_joint_windows(raw, model.normalization(), window, options.corruption_probability, options.corruption_seed),
        truth_mm);
    errors["window_frames"] = window;
    result["joint_windows"].push_back(errors);
  }
  return result;
}

}  // namespace

std::string evaluate_reconstruction(const MotionManifold& model, const std::vector<const PreparedSequence*>& test,
                                    const EvaluationOptions& options) {
  c10::InferenceMode inference;
  const auto& config = model.config();
  if (config.frames % options.intervals != 0) {
    throw InputError("intervals: " + std::to_string(options.intervals) + " does not divide the clip's " +
                     std::to_string(config.frames) + " frames");
  }
  ClipSampler sampler(test, config.frames, options.seed);
  std::vector<ClipSampler::Clip> clips;
  nlohmann::json clip_list = nlohmann::json::array();
  for (int i = 0; i < options.clips; ++i) {
    clips.push_back(sampler.draw());
    const auto& c = clips.back();
    clip_list.push_back({{"subject", c.sequence->subject},
                         {"action", c.sequence->action},
                         {"take", c.sequence->take},
                         {"phase", c.sequence->phase},
                         {"start", c.start}});
  }
  auto motion = sampler.gather(clips).to(model.device());
  auto code = model.encode(motion);
  auto truth_scaled = model.positions_scaled(motion);
  auto truth_mm = model.positions_mm(motion);
  const int joints = model.skeleton().joint_count();
  // Joints the model animates: those with at least one kept column.
  std::set<int64_t> animated;
  for (int c : model.normalization().kept_columns) animated.insert((c - 3) / 3);
  auto animated_index = at::tensor(std::vector<int64_t>(animated.begin(), animated.end()), at::kLong).to(model.device());
  auto rotations = [&](const at::Tensor& normalized) {
    auto raw = model.to_raw(normalized);
    auto expmaps = raw.narrow(-1, 3, 3 * joints).reshape({raw.size(0), raw.size(1), joints, 3});
    return expmap_to_rotation_matrix(expmaps.index_select(2, animated_index));
  };
  auto truth_rotations = rotations(motion);

  nlohmann::json decoders = nlohmann::json::object();
  for (auto kind : {DecoderKind::kRotation, DecoderKind::kVelocity}) {
    if (!model.has_decoder(kind)) continue;
    auto decoded = model.decode(code, kind);
    auto recoded = model.encode(decoded);
    decoders[decoder_name(kind)] = {
        {"E_r", per_interval(frame_norm(decoded - motion, 1), options.intervals)},
        {"E_p", per_interval(frame_norm(model.positions_scaled(decoded) - truth_scaled, 2), options.intervals)},
        {"E_z", (recoded - code).abs().mean().item<double>()},
        {"mpjpe_mm", per_interval((model.positions_mm(decoded) - truth_mm).norm(2, -1).mean(-1), options.intervals)},
        {"angle_error_rad",
         per_interval(rotation_angle_between(rotations(decoded), truth_rotations).mean(-1), options.intervals)},
    };
  }
  const double interval_seconds = static_cast<double>(config.frames) / options.intervals / 25.0;
  nlohmann::json result = {
      {"clips", options.clips},
      {"seed", options.seed},
      {"frames", config.frames},
      {"frame_rate", 25},
      {"interval_seconds", interval_seconds},
      {"position_unit_mm", model.normalization().position_scale_mm},
      {"decoders", decoders},
      {"test_clips", clip_list},
  };
  if (options.corruption_probability > 0) result["denoising"] = evaluate_denoising(model, motion, truth_mm, options);
  return result.dump(2);
}

}  // namespace mm
