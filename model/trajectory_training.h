// Training the root trajectory network (root_trajectory.h) of a trained
// manifold, which stays as it is: a pool of windows of the model's clip
// length is drawn from motions with their true root changes and encoded
// and decoded once; each batch is half reconstructions, half recorded
// poses, each with its window's code, so that the network learns from what
// it will be given at inference. Loss: the squared error of each frame's
// root move and turn plus a tenth of the squared error of the path and
// heading they add up to (in units of kTrajectoryOutputMm and
// kTrajectoryOutputRadians), which keeps a clip's drift down where
// per-frame errors share a sign.
//
// Thread safety: one training at a time per model; nothing else may use
// the model meanwhile.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "format/motion_text.h"
#include "model/motion_manifold.h"
#include "model/root_trajectory.h"

namespace mm {

struct TrajectoryTrainingOptions {
  TrajectoryConfig shape;
  int iterations = 3000;
  int batch = 32;
  double learning_rate = 1e-3;
  uint64_t seed = 1;
  // Windows in the pool (each encoded and decoded once).
  int windows = 4096;
  // Called every 100 iterations and at the end with the iteration and the
  // mean loss since the last call.
  std::function<void(int, double)> progress;
};

struct TrajectoryTrainingReport {
  int iterations = 0;
  double final_loss = 0;  // mean over the last 100 iterations
  double seconds = 0;
  int64_t windows_available = 0;  // distinct window starts in the motions
};

// Trains a fresh network on `motions` (25 Hz, the model's layout: for
// H3.6M columns 0..5 the root's true changes per frame,
// split_phases_keeping_root_path; for a rig read from BVH its world layout
// as skeleton_motion_from_bvh gives it, root_path.h's kHeadingMoves)
// and installs it in `model` with its training recorded in the manifest.
// InputError when no motion holds a window of config().frames + 1 frames.
TrajectoryTrainingReport train_root_trajectory(MotionManifold& model, const std::vector<MotionFrames>& motions,
                                               const TrajectoryTrainingOptions& options);

}  // namespace mm
