// Table 1's errors in the units of the public reference implementation of
// the paper (DK-Jang/human_motion_manifold), in which the paper's numbers are
// most likely reported. They differ from the evaluation's own units (one
// norm over every value of a frame; see evaluation.h):
//   angles     the normalised pose values taken as consecutive triplets (the
//              paper's "17 joints" for H3.6M's 51 values), the mean of each
//              triplet's Euclidean norm (the reference's reconstruction
//              criterion and test loss);
//   positions  FK joint coordinates (mm) standardised per coordinate by the
//              training frames' mean and standard deviation, coordinates with
//              a std below 1e-4 dropped and every other one kept however
//              small its std, the rest as consecutive triplets, the mean of
//              each triplet's norm;
//   latent     the mean absolute difference of z and Enc(Dec(z)), which the
//              evaluation's E_z already is.
// The reference keeps the root's height in its positions; the H3.6M text
// layout holds the root's per-frame displacement, not its height, so here
// the root stays at the origin and its three coordinates, which never vary,
// are dropped. Where the reference takes the kept coordinates as
// consecutive triplets, this takes each joint's kept coordinates as its
// triplet and averages over the joints with any kept: the same whenever
// whole joints are dropped (the training subjects of H3.6M: the root), and
// still joints where a coordinate of a joint that hardly moves falls below
// the threshold alone (joint 11, 0.1 mm from the root, on subject S1 only),
// where the reference's triplets would shift by one.
//
// Thread safety: pure functions and an immutable value type; safe to call
// concurrently.
#pragma once

#include <ATen/ATen.h>

#include <vector>

#include "format/prepared_dataset.h"
#include "model/motion_manifold.h"

namespace mm {

// The mean over consecutive triplets of the last dimension of each
// triplet's Euclidean norm: (..., 3k) -> (...). InputError if the last
// dimension is not a multiple of 3.
at::Tensor mean_triplet_norm(const at::Tensor& difference);

// Per-coordinate standardisation of joint positions, fitted on training
// frames as the reference does.
struct CoordinateStandardization {
  at::Tensor mean;    // (C) float64, per coordinate, mm
  at::Tensor stddev;  // (C) float64, population std, mm
  at::Tensor kept;    // (C) bool: stddev >= min_std
  int64_t frames = 0; // frames it was fitted on

  // coordinates: (N, C) over N frames, C = 3 x joints. InputError if N is
  // zero, C is not a multiple of 3, or no coordinate varies.
  static CoordinateStandardization fit(const at::Tensor& coordinates, double min_std = 1e-4);
  int64_t kept_count() const;
  // (..., C) -> (..., C) standardised coordinates, float64, with the dropped
  // ones zero.
  at::Tensor apply(const at::Tensor& coordinates) const;
};

// Fits the standardisation on the FK positions (mm, root at the origin) of
// every frame of the given sequences, normalised as the model's own
// normalisation (the evaluation re-normalises a dataset of other statistics
// first). Runs in chunks, so memory stays small; about ten seconds for
// H3.6M's training subjects on two cores.
CoordinateStandardization fit_position_standardization(const MotionManifold& model,
                                                       const std::vector<const PreparedSequence*>& sequences);

// Per-frame errors in the reference's units: q_hat, q (B, T, D) normalised
// poses -> (B, T); p_hat, p (B, T, J, 3) positions in mm -> (B, T).
at::Tensor paper_angle_error(const at::Tensor& q_hat, const at::Tensor& q);
at::Tensor paper_position_error(const CoordinateStandardization& standardization, const at::Tensor& p_hat_mm,
                                const at::Tensor& p_mm);

}  // namespace mm
