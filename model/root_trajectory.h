// The root's path for motion the manifold generates. The paper models the
// poses only (the root translation is dropped), so a decoded walk would walk
// on the spot; this small network, trained on the training subjects' root
// motion with the manifold left as it is, predicts from the decoded poses
// how far the root moves between frames. The decoded poses already hold the
// root's rotation from frame to frame (the H3.6M layout records it as a
// change), so the two together are the root's path in the world
// (format/root_path.h), put on the floor under the feet.
//
// The network: 1-D convolutions over time (kernel 5, replicate padding,
// ReLU between layers) from the normalised poses (B, T, pose_dims) and the
// clip's code (B, latent), given to every frame, to the root's move and turn
// from each frame to the next, (B, T, 6): x, y, z in mm at 25 Hz in the
// root's own axes and the rotation change as an exponential map (radians
// per 50 Hz step), as the layout records them. The decoded poses' own
// rotation change turns about half as much as the recording (on S5 walking
// its standard deviation is 0.008 against 0.016 rad): the code, which the
// encoder made from the recording's, says more of where the clip turns.
// Three layers of 64 channels see 13 frames (0.5 s) around each frame.
//
// Thread safety: as Encoder; forward() may be called concurrently in eval
// mode without autograd.
#pragma once

#include <ATen/ATen.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/pimpl.h>

#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

class MotionManifold;

struct TrajectoryConfig {
  int hidden = 64;  // channels of the hidden layers
  int layers = 3;   // convolutions of kernel 5 (then one of kernel 1)
  int kernel = 5;
};
std::string to_json_text(const TrajectoryConfig& config);
// InputError naming `source` for a missing or out-of-range field.
TrajectoryConfig trajectory_config_from_json_text(const std::string& text, const std::string& source);

// The unit of the network's output: 20 mm per 25 Hz frame (0.5 m/s), about
// a walk's step per frame, so outputs are of order one.
constexpr double kTrajectoryOutputMm = 20.0;
// The unit of its rotation outputs: 0.02 rad per 50 Hz step, a brisk turn
// (180 degrees in 3 s).
constexpr double kTrajectoryOutputRadians = 0.02;

// The H3.6M layout's rotation changes are of the files' 50 Hz frames, and a
// model frame at 25 Hz holds one of two: each stands for two steps.
constexpr double kRootRotationStepsPerFrame = 2.0;

class RootTrajectoryImpl : public torch::nn::Module {
 public:
  RootTrajectoryImpl(int pose_dims, int latent, const TrajectoryConfig& config);

  // poses (B, T, pose_dims) normalised and codes (B, latent) -> (B, T, 6):
  // the root's move from frame t to frame t + 1 in frame t's root axes
  // (mm) and its rotation change at frame t + 1 (radians per 50 Hz step).
  at::Tensor forward(const at::Tensor& poses, const at::Tensor& codes);

  const TrajectoryConfig& config() const { return config_; }

 private:
  TrajectoryConfig config_;
  torch::nn::ModuleList layers_;
};
TORCH_MODULE(RootTrajectory);

// Writes the predicted root changes of clips `normalized` (B, T, D),
// decoded from `codes` (B, latent), into raw frames `raw` (B x T frames of
// `columns` values, contiguous): columns 0..2 of frame f the move from
// frame f - 1 in its root axes, columns 3..5 the rotation change (0 in
// frame 0), the layout's root-change form; RootPathIntegrator turns them
// into a path once the frames are final. Requires model.has_trajectory().
void write_generated_root_changes(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& codes,
                                  float* raw, int64_t columns);

// Writes the generated root of each clip into `motions` (raw frames of the
// model's layout, one per clip of `normalized`, (B, T, D) on the model's
// device) and turns each into world layout (integrate_level_root_path):
// columns 0..2 the root's move in world axes (frame 0: its start, (0,
// height, 0)), columns 3..5 its world orientation, settled on the floor at
// y = 0 (settle_on_floor).
// Requires model.has_trajectory().
void write_generated_roots(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& codes,
                           std::vector<MotionFrames>& motions);

}  // namespace mm
