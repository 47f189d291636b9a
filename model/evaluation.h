// Table 1 of the paper: reconstruction errors of a model on a fixed, seeded
// set of test clips, per 1.2 s interval, in the paper's normalised units and
// in physical units.
//
// Thread safety: reads the model only; may run beside other inference.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/prepared_dataset.h"
#include "model/motion_manifold.h"
#include "model/paper_units.h"

namespace mm {

struct EvaluationOptions {
  int clips = 30;       // the paper averages 30 random test motions
  uint64_t seed = 0;    // fixes which clips
  int intervals = 5;    // 150 frames in 5 intervals of 1.2 s
  // Sampling noise: with n > 1, the Table 1 numbers are also computed on the
  // clip sets of seeds seed .. seed + n - 1 and reported as mean and sample
  // standard deviation over them ("seed_spread").
  int spread_seeds = 1;
  // Denoising experiment (Sec. 5.4) on the same clips: each modelled joint
  // angle dropped with this probability; 0 leaves it out.
  double corruption_probability = 0.5;
  uint64_t corruption_seed = 0;
};

// For each decoder of the model, per interval:
//   E_r  mean over clips and frames of |q_hat - q| over the normalised pose;
//   E_p  the same for joint positions over all 32 joints, in the model's
//        position unit (mm / position_scale_mm);
//   mpjpe_mm  mean per-joint position error in millimetres;
//   angle_error_rad  mean geodesic angle between predicted and true joint
//        rotations, over the joints the model animates;
// and E_z, the mean absolute difference between z and Enc(Dec(z)). Beside
// them "paper_units": E_r, E_p and E_z in the units of the public reference
// implementation (paper_units.h); E_p there needs the per-coordinate
// position statistics of the training frames (`positions`; without them
// paper_units has no E_p), and E_r a multiple of 3 pose values (without
// one it has no E_r).
// Intervals are in clip time (the first is the clip's first 1.2 s);
// "generation_order" repeats every per-interval array (and those of
// "seed_spread") reversed, in the order the decoders generate the frames (they
// run in reverse time, so the first interval generated is the clip's end).
// With more than one clip, "prior_match": the mean and sample covariance of
// the clips' codes (mean_norm, mean_abs_max, variance_mean/min/max,
// covariance_off_diagonal_abs_mean; N(0, I) has 0, 0, 1, 1, 1, 0) and Eq.
// 12's MMD (single scale, diagonal left out) of the codes to as many draws
// from N(0, I), beside the MMD between two such draws (the value of a
// perfect match at this number of clips), both averaged over 20 draws of a
// generator seeded with the evaluation's seed.
// With a corruption probability, also "denoising": for each corruption (the
// reference's, then the paper's zeroing, then whole joints missing over 1.2 s
// and over the whole clip, as when a marker is lost) the mean per-joint
// position error in mm against the clean clips of the corrupted clips, of
// their projections onto the manifold (default decoder) as the paper
// projects them, of the projections that treat the dropped values as missing
// (DenoiseOptions), of the same keeping the observed values, and of a
// baseline without the manifold that interpolates the dropped values in
// time.
// Returns JSON text (documented in docs/ and by the tool). InputError if the
// test sequences hold no clip of the model's length.
std::string evaluate_reconstruction(const MotionManifold& model, const std::vector<const PreparedSequence*>& test,
                                    const EvaluationOptions& options,
                                    const CoordinateStandardization* positions = nullptr);

}  // namespace mm
