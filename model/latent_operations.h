// The operations on the manifold that the applications of Sec. 5 and the
// service use: encode, decode, sample, interpolate, analogy, denoise, and the
// paper's corruption for the denoising experiment.
//
// Motions are raw frames in the input's layout (MotionFrames with the
// normalisation's input columns, 99 for H3.6M, radians) at 25 Hz and exactly
// config().frames long. Codes are (latent) or (n, latent) float tensors on
// the CPU. Bad input (wrong frame or column count, wrong code size) is an
// InputError naming the argument, the value and what was expected.
//
// Thread safety: all functions may be called concurrently on one model.
#pragma once

#include <ATen/ATen.h>

#include <cstdint>
#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "model/motion_manifold.h"

namespace mm {

// Codes of the motions, (n, latent).
at::Tensor encode_motions(const MotionManifold& model, const std::vector<MotionFrames>& motions);

// One motion per row of codes (n, latent), un-normalised. The root
// translation columns are copied from `translation_from` (same count as
// codes) when given; otherwise they hold the root path the model's
// trajectory network generates (root_trajectory.h: it travels, with the
// lowest foot on the floor), or zero for a model without one.
std::vector<MotionFrames> decode_codes(const MotionManifold& model, const at::Tensor& codes, DecoderKind kind,
                                       const std::vector<MotionFrames>* translation_from = nullptr);

// plant_feet (format/foot_contacts.h) on each of `motions` (world layout at
// `rate_hz`), the motions spread over LibTorch's threads, so that a batch's
// correction costs about what one core's share of it does. Safe to call
// from several threads at once.
void plant_feet_of_each(const Skeleton& skeleton, std::vector<MotionFrames>& motions, double rate_hz);

// n codes drawn from the prior N(0, prior_variance I), reproducible by seed.
at::Tensor sample_codes(const MotionManifold& model, int n, uint64_t seed, double prior_variance = 1.0);

// `steps` codes from a to b inclusive (steps >= 2): linear, or spherical
// (slerp on the angle between a and b, scaled by the interpolated norm;
// linear when either code is zero, which has no direction).
at::Tensor interpolate_codes(const at::Tensor& a, const at::Tensor& b, int steps, bool spherical);

// a - b + c (Sec. 5.5).
at::Tensor analogy_code(const at::Tensor& a, const at::Tensor& b, const at::Tensor& c);

// How denoise_motions reads its input.
struct DenoiseOptions {
  // Treat a modelled joint-angle value that is exactly zero as missing. The
  // corruption of Sec. 5.4 as the paper states it drops values by zeroing
  // them, while captured rotations almost never hold an exact zero, so the
  // zeros say which values carry no information. Off: every value is taken
  // as observed (the paper).
  bool zeros_are_missing = false;
  // With missing values: rounds of projecting onto the manifold and refilling
  // the missing values from the decoded motion (they start at the training
  // mean). The fill settles after about four rounds on H3.6M.
  int iterations = 4;
  // With missing values: return the observed values as they are and the
  // manifold's values only where values are missing (gap filling), instead
  // of the decoded motion throughout. Only with zeros_are_missing or
  // means_are_missing.
  bool keep_observed = false;
  // Treat a modelled value exactly equal to its training mean as missing:
  // the reference implementation's corruption (Corruption::kReference)
  // leaves its dropped values there. Not together with zeros_are_missing.
  bool means_are_missing = false;
};

// Projects each motion onto the manifold and decodes it (Sec. 5.4); root
// translation is carried over from the input.
std::vector<MotionFrames> denoise_motions(const MotionManifold& model, const std::vector<MotionFrames>& motions,
                                          DecoderKind kind, const DenoiseOptions& options = {});

// The same on normalised clips (B, frames, D) on the model's device.
// `missing` is an undefined tensor (nothing missing) or a bool mask of the
// clips' shape; missing values start at the training mean (zero, normalised)
// and are refilled from the decoded motion `iterations` times. `codes`, when
// given, receives the codes (B, latent) the result was decoded from (the
// last round's), so that a caller that reports codes need not encode again.
at::Tensor project_onto_manifold(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& missing,
                                 DecoderKind kind, int iterations, at::Tensor* codes = nullptr);

// Bool mask (..., D) of the modelled values that `options` says are
// missing in raw frames (..., input columns): exactly zero
// (zeros_are_missing) or exactly the training mean (means_are_missing); an
// undefined tensor when neither is set. InputError when both are set.
at::Tensor missing_values_mask(const MotionManifold& model, const at::Tensor& raw, const DenoiseOptions& options);

// The two corruptions of the denoising experiment (Sec. 5.4). Each drops
// every modelled joint-angle value of every frame with a probability; they
// differ in what a dropped value becomes.
enum class Corruption {
  // The public reference implementation: the normalised clip times a random
  // 0/1 mask, so a dropped value becomes its training mean.
  kReference,
  // The paper's text: the raw value (radians) set to zero, which for some
  // values lies more than ten standard deviations from the mean.
  kZeroed,
};
const char* corruption_name(Corruption corruption);  // "reference" / "zeroed"
// Parses "reference" or "zeroed"; InputError naming the value otherwise.
Corruption parse_corruption(const std::string& name);

// Drops values as `corruption` says, reproducibly by seed: the same seed
// drops the same values under either corruption.
MotionFrames corrupt_motion(const MotionFrames& motion, const PoseNormalization& normalization, double probability,
                            uint64_t seed, Corruption corruption = Corruption::kZeroed);

}  // namespace mm
