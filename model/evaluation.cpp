#include "evaluation.h"

#include <c10/core/InferenceMode.h>

#include <nlohmann/json.hpp>
#include <cstring>
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
  auto corrupted_normalized = model.to_normalized(corrupted.to(model.device()));
  const auto kind = model.default_decoder();
  auto denoised = model.decode(model.encode(corrupted_normalized), kind);
  return {{"probability", options.corruption_probability},
          {"seed", options.corruption_seed},
          {"decoder", decoder_name(kind)},
          {"corrupted_mpjpe_mm", mean_joint_error_mm(model.positions_mm(corrupted_normalized), truth_mm)},
          {"denoised_mpjpe_mm", mean_joint_error_mm(model.positions_mm(denoised), truth_mm)}};
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
