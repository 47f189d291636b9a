#include "model/evaluation.h"

#include <algorithm>
#include <c10/core/InferenceMode.h>

#include <nlohmann/json.hpp>
#include <cmath>
#include <cstring>
#include <utility>
#include <map>
#include <random>
#include <set>

#include "format/input_error.h"
#include "model/clip_sampler.h"
#include "model/latent_operations.h"
#include "model/losses.h"
#include "model/rotation.h"

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
// dropped values `missing` says how to find: as they are, projected as they
// are (the paper), projected with the dropped values as missing, the same
// keeping the observed values, and interpolated in time.
nlohmann::json missing_value_errors(const MotionManifold& model, const at::Tensor& corrupted, const at::Tensor& truth_mm,
                                    const DenoiseOptions& missing_options) {
  const auto kind = model.default_decoder();
  const auto on_device = corrupted.to(model.device());
  const auto normalized = model.to_normalized(on_device);
  const auto missing = missing_values_mask(model, on_device, missing_options);
  const int rounds = missing_options.iterations;
  const auto filled = project_onto_manifold(model, normalized, missing, kind, rounds);
  auto error_mm = [&](const at::Tensor& n) { return mean_joint_error_mm(model.positions_mm(n), truth_mm); };
  return {{"missing_values", missing_options.means_are_missing ? "training mean" : "zero"},
          {"missing_fraction", missing.to(at::kFloat).mean().item<double>()},
          {"corrupted_mpjpe_mm", error_mm(normalized)},
          {"denoised_mpjpe_mm", error_mm(project_onto_manifold(model, normalized, {}, kind, 1))},
          {"denoised_missing_mpjpe_mm", error_mm(filled)},
          {"filled_missing_mpjpe_mm", error_mm(at::where(missing, filled, normalized))},
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

// Each clip of raw frames (N, T, C) corrupted by corrupt_motion, clip i with
// seed + i.
at::Tensor corrupt_clips(const at::Tensor& raw, const PoseNormalization& normalization, double probability,
                         uint64_t seed, Corruption corruption) {
  const int64_t clips = raw.size(0), frames = raw.size(1), columns = raw.size(2);
  auto corrupted = at::empty_like(raw);
  for (int64_t i = 0; i < clips; ++i) {
    MotionFrames clip;
    clip.columns = static_cast<int>(columns);
    clip.values.assign(raw[i].data_ptr<float>(), raw[i].data_ptr<float>() + frames * columns);
    const auto noisy = corrupt_motion(clip, normalization, probability, seed + static_cast<uint64_t>(i), corruption);
    std::memcpy(corrupted[i].data_ptr<float>(), noisy.values.data(), sizeof(float) * frames * columns);
  }
  return corrupted;
}

nlohmann::json evaluate_denoising(const MotionManifold& model, const at::Tensor& motion, const at::Tensor& truth_mm,
                                  const EvaluationOptions& options) {
  const auto raw = model.to_raw(motion).cpu().contiguous();
  const auto& normalization = model.normalization();
  DenoiseOptions zeros, means;
  zeros.zeros_are_missing = true;
  means.means_are_missing = true;
  nlohmann::json corruptions = nlohmann::json::array();
  // The reference's corruption first (dropped values at the training mean),
  // then the paper's text (dropped values zeroed), on the same dropped values.
  for (auto corruption : {Corruption::kReference, Corruption::kZeroed}) {
    auto errors = missing_value_errors(
        model, corrupt_clips(raw, normalization, options.corruption_probability, options.corruption_seed, corruption),
        truth_mm, corruption == Corruption::kReference ? means : zeros);
    errors["corruption"] = corruption_name(corruption);
    corruptions.push_back(errors);
  }
  // Whole joints missing (all their values zero) over 1.2 s and over the
  // whole clip.
  const int64_t frames = raw.size(1);
  for (int64_t window : {frames / 5, frames}) {
    auto errors = missing_value_errors(
        model, zero_joint_windows(raw, normalization, window, options.corruption_probability, options.corruption_seed),
        truth_mm, zeros);
    errors["corruption"] = "joint_window";
    errors["window_frames"] = window;
    corruptions.push_back(errors);
  }
  return {{"probability", options.corruption_probability},
          {"seed", options.corruption_seed},
          {"decoder", decoder_name(model.default_decoder())},
          {"missing_iterations", DenoiseOptions{}.iterations},
          {"corruptions", corruptions}};
}

// Table 1 for one set of clips (B, frames, D): per decoder, the errors in
// the evaluation's units, the physical ones and those of the reference.
nlohmann::json table1(const MotionManifold& model, const at::Tensor& motion, const CoordinateStandardization* positions,
                      int intervals) {
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
    auto decoded_mm = model.positions_mm(decoded);
    const double e_z = (model.encode(decoded) - code).abs().mean().item<double>();
    // The reference's triplets need a multiple of 3 pose values (51 for H3.6M).
    nlohmann::json paper = nlohmann::json::object();
    if (motion.size(-1) % 3 == 0) paper["E_r"] = per_interval(paper_angle_error(decoded, motion), intervals);
    if (positions) paper["E_p"] = per_interval(paper_position_error(*positions, decoded_mm, truth_mm), intervals);
    paper["E_z"] = e_z;
    decoders[decoder_name(kind)] = {
        {"E_r", per_interval(frame_norm(decoded - motion, 1), intervals)},
        {"E_p", per_interval(frame_norm(decoded_mm / model.normalization().position_scale_mm - truth_scaled, 2), intervals)},
        {"E_z", e_z},
        {"mpjpe_mm", per_interval((decoded_mm - truth_mm).norm(2, -1).mean(-1), intervals)},
        {"angle_error_rad", per_interval(rotation_angle_between(rotations(decoded), truth_rotations).mean(-1), intervals)},
        {"paper_units", paper},
    };
  }
  return decoders;
}

// How well the codes of the test clips (n, latent) match the prior N(0, I)
// the training pulls them to (Eq. 12): their mean and sample covariance, and
// Eq. 12's MMD to n prior draws beside the MMD between two sets of n prior
// draws (what a perfect match measures at this n), each averaged over
// `draws` draws from a generator seeded `seed`.
nlohmann::json prior_match(const at::Tensor& codes, uint64_t seed, int draws) {
  const auto c = codes.to(at::kCPU).to(at::kDouble);
  const int64_t n = c.size(0);
  const auto mean = c.mean(0);
  const auto centred = c - mean;
  const auto covariance = centred.t().mm(centred) / static_cast<double>(n - 1);
  const auto variances = covariance.diagonal();
  const auto off_diagonal = covariance - at::diag(variances);
  const int64_t latent = c.size(1);
  auto generator = at::detail::createCPUGenerator(seed);
  double codes_to_prior = 0, prior_to_prior = 0;
  for (int k = 0; k < draws; ++k) {
    const auto prior = at::randn({n, latent}, generator, at::kDouble);
    const auto other = at::randn({n, latent}, generator, at::kDouble);
    codes_to_prior += mmd_inverse_multiquadratic(c, prior, 1.0).item<double>() / draws;
    prior_to_prior += mmd_inverse_multiquadratic(other, prior, 1.0).item<double>() / draws;
  }
  return {{"codes", n},
          {"prior", "N(0, I)"},
          {"draws", draws},
          {"seed", seed},
          {"mmd_codes_to_prior", codes_to_prior},
          {"mmd_prior_to_prior", prior_to_prior},
          {"mean_norm", mean.norm().item<double>()},
          {"mean_abs_max", mean.abs().max().item<double>()},
          {"variance_mean", variances.mean().item<double>()},
          {"variance_min", variances.min().item<double>()},
          {"variance_max", variances.max().item<double>()},
          {"covariance_off_diagonal_abs_mean",
           latent > 1 ? off_diagonal.abs().sum().item<double>() / static_cast<double>(latent * (latent - 1)) : 0.0}};
}

// The mean and sample standard deviation over documents of one shape, leaf
// by leaf: a number becomes {"mean", "std"}, an array of numbers two arrays.
nlohmann::json mean_and_std(const std::vector<nlohmann::json>& documents) {
  const auto& first = documents.front();
  if (first.is_object()) {
    nlohmann::json result = nlohmann::json::object();
    for (const auto& [key, unused] : first.items()) {
      std::vector<nlohmann::json> children;
      for (const auto& d : documents) children.push_back(d.at(key));
      result[key] = mean_and_std(children);
    }
    return result;
  }
  auto values = [&](const nlohmann::json& d) { return d.is_array() ? d.get<std::vector<double>>() : std::vector<double>{d.get<double>()}; };
  const size_t width = values(first).size();
  std::vector<double> mean(width, 0.0), spread(width, 0.0);
  for (const auto& d : documents) {
    const auto v = values(d);
    for (size_t i = 0; i < width; ++i) mean[i] += v.at(i) / static_cast<double>(documents.size());
  }
  for (const auto& d : documents) {
    const auto v = values(d);
    for (size_t i = 0; i < width; ++i) spread[i] += (v.at(i) - mean[i]) * (v.at(i) - mean[i]);
  }
  for (auto& s : spread) s = documents.size() > 1 ? std::sqrt(s / static_cast<double>(documents.size() - 1)) : 0.0;
  if (first.is_array()) return {{"mean", mean}, {"std", spread}};
  return {{"mean", mean[0]}, {"std", spread[0]}};
}

// The per-interval numbers in the order the decoders generate frames: they
// run in reverse time (Sec. 3.2.3), so the first interval
// generated is the clip's last. Every array of `intervals` numbers is
// reversed; everything else is kept.
nlohmann::json in_generation_order(const nlohmann::json& document, size_t intervals) {
  if (document.is_object()) {
    nlohmann::json result = nlohmann::json::object();
    for (const auto& [key, value] : document.items()) result[key] = in_generation_order(value, intervals);
    return result;
  }
  if (document.is_array() && document.size() == intervals && !document.empty() && document.front().is_number()) {
    auto reversed = document.get<std::vector<double>>();
    std::reverse(reversed.begin(), reversed.end());
    return reversed;
  }
  return document;
}

}  // namespace

std::string evaluate_reconstruction(const MotionManifold& model, const std::vector<const PreparedSequence*>& test,
                                    const EvaluationOptions& options, const CoordinateStandardization* positions) {
  c10::InferenceMode inference;
  const auto& config = model.config();
  if (config.frames % options.intervals != 0) {
    throw InputError("intervals", std::to_string(options.intervals) + " does not divide the clip's " +
                     std::to_string(config.frames) + " frames");
  }
  if (options.spread_seeds < 1) {
    throw InputError("spread_seeds", "expected at least 1, found " + std::to_string(options.spread_seeds));
  }
  auto draw_clips = [&](uint64_t seed) {
    ClipSampler sampler(test, config.frames, seed);
    std::vector<ClipSampler::Clip> clips;
    for (int i = 0; i < options.clips; ++i) clips.push_back(sampler.draw());
    return std::make_pair(clips, sampler.gather(clips).to(model.device()));
  };
  const auto [clips, motion] = draw_clips(options.seed);
  nlohmann::json clip_list = nlohmann::json::array();
  for (const auto& c : clips) {
    clip_list.push_back({{"subject", c.sequence->subject},
                         {"action", c.sequence->action},
                         {"take", c.sequence->take},
                         {"phase", c.sequence->phase},
                         {"start", c.start}});
  }
  const auto decoders = table1(model, motion, positions, options.intervals);
  const double interval_seconds = static_cast<double>(config.frames) / options.intervals / 25.0;
  nlohmann::json paper_units = {
      {"angles", model.normalization().dims() % 3 == 0
                     ? "mean over the consecutive triplets of the normalised pose values of each triplet's norm"
                     : "not computed: the pose values are not a multiple of 3, so they form no triplets"},
      {"positions", positions ? "FK coordinates (mm, root at the origin) standardised per coordinate by the training "
                                "frames' mean and std, coordinates with std < 1e-4 mm dropped, mean over the joints' "
                                "triplets of each norm"
                              : "not computed: no training frames given for the per-coordinate statistics"},
  };
  if (positions) {
    paper_units["position_statistics_frames"] = positions->frames;
    paper_units["position_coordinates_kept"] = positions->kept_count();
    paper_units["position_coordinates"] = positions->stddev.numel();
    const auto dropped = positions->kept.logical_not().nonzero().flatten().contiguous();
    paper_units["position_coordinates_dropped"] =
        std::vector<int64_t>(dropped.data_ptr<int64_t>(), dropped.data_ptr<int64_t>() + dropped.numel());
  }
  nlohmann::json result = {
      {"clips", options.clips},
      {"seed", options.seed},
      {"frames", config.frames},
      {"frame_rate", 25},
      {"interval_seconds", interval_seconds},
      {"interval_order",
       "clip time: the first number is the clip's first interval; generation_order holds the same numbers from "
       "the clip's end, the order in which the decoders generate the frames"},
      {"position_unit_mm", model.normalization().position_scale_mm},
      {"paper_units", paper_units},
      {"decoders", decoders},
      {"test_clips", clip_list},
  };
  if (options.spread_seeds > 1) {
    std::vector<nlohmann::json> tables{decoders};
    nlohmann::json seeds = {options.seed};
    for (int k = 1; k < options.spread_seeds; ++k) {
      const uint64_t seed = options.seed + static_cast<uint64_t>(k);
      tables.push_back(table1(model, draw_clips(seed).second, positions, options.intervals));
      seeds.push_back(seed);
    }
    result["seed_spread"] = {{"seeds", seeds},
                             {"clips_per_seed", options.clips},
                             {"statistics", "mean and sample standard deviation over the seeds' clip sets"},
                             {"decoders", mean_and_std(tables)}};
  }
  const auto intervals = static_cast<size_t>(options.intervals);
  result["generation_order"] = {{"decoders", in_generation_order(decoders, intervals)}};
  if (result.contains("seed_spread")) {
    result["generation_order"]["seed_spread_decoders"] =
        in_generation_order(result["seed_spread"]["decoders"], intervals);
  }
  if (options.clips > 1) result["prior_match"] = prior_match(model.encode(motion), options.seed, 20);
  if (options.corruption_probability > 0) {
    result["denoising"] = evaluate_denoising(model, motion, model.positions_mm(motion), options);
  }
  return result.dump(2);
}

}  // namespace mm
