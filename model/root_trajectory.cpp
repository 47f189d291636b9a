#include "model/root_trajectory.h"

#include <ATen/Parallel.h>
#include <c10/core/InferenceMode.h>
#include <torch/nn/functional/activation.h>
#include <torch/nn/modules/conv.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "format/json_text.h"
#include "format/root_path.h"
#include "model/motion_manifold.h"

namespace mm {

std::string to_json_text(const TrajectoryConfig& config) {
  return nlohmann::json{{"hidden", config.hidden}, {"layers", config.layers}, {"kernel", config.kernel}}.dump();
}

TrajectoryConfig trajectory_config_from_json_text(const std::string& text, const std::string& source) {
  const nlohmann::json json = parse_json_text(text, source);
  TrajectoryConfig config;
  auto read = [&](const char* key, int low, int high) {
    if (!json.is_object() || !json.contains(key) || !json[key].is_number_integer()) {
      throw InputError(source + ": " + key + ": expected an integer");
    }
    const int value = json[key].get<int>();
    if (value < low || value > high) {
      throw InputError(source + ": " + key + ": expected " + std::to_string(low) + " to " + std::to_string(high) +
                       ", found " + std::to_string(value));
    }
    return value;
  };
  config.hidden = read("hidden", 1, 4096);
  config.layers = read("layers", 1, 16);
  config.kernel = read("kernel", 1, 31);
  if (config.kernel % 2 == 0) throw InputError(source + ": kernel: expected an odd number, found " + std::to_string(config.kernel));
  return config;
}

RootTrajectoryImpl::RootTrajectoryImpl(int pose_dims, int latent, const TrajectoryConfig& config) : config_(config) {
  layers_ = register_module("layers", torch::nn::ModuleList());
  int channels = pose_dims + latent;
  for (int i = 0; i < config.layers; ++i) {
    layers_->push_back(torch::nn::Conv1d(torch::nn::Conv1dOptions(channels, config.hidden, config.kernel)
                                             .padding(config.kernel / 2)
                                             .padding_mode(torch::kReplicate)));
    channels = config.hidden;
  }
  layers_->push_back(torch::nn::Conv1d(torch::nn::Conv1dOptions(channels, 6, 1)));
}

at::Tensor RootTrajectoryImpl::forward(const at::Tensor& poses, const at::Tensor& codes) {
  // The first layer reads each frame's pose and the clip's code. The code
  // is the same in every frame, and replicate padding keeps it so: its part
  // of the convolution is the same in every frame too, one product per clip
  // with the kernel's taps summed, added to the poses' part. Convolving the
  // code at every frame instead was a quarter of the network's arithmetic.
  const auto& first = *layers_[0]->as<torch::nn::Conv1d>();
  const int64_t pose_dims = poses.size(2), pad = first.options.kernel_size()->front() / 2;
  const auto pose_weight = first.weight.narrow(1, 0, pose_dims);
  const auto code_weight = first.weight.narrow(1, pose_dims, first.weight.size(1) - pose_dims).sum(2);  // (H, latent)
  auto x = at::conv1d(at::replication_pad1d(poses.transpose(1, 2), {pad, pad}), pose_weight, first.bias) +
           at::linear(codes.to(poses.dtype()), code_weight).unsqueeze(2);  // (B, H, T)
  for (size_t i = 1; i < layers_->size(); ++i) {
    x = layers_[i]->as<torch::nn::Conv1d>()->forward(at::relu(x));
  }
  x = x.transpose(1, 2);
  return at::cat({x.narrow(2, 0, 3) * kTrajectoryOutputMm, x.narrow(2, 3, 3) * kTrajectoryOutputRadians}, 2);
}

void write_generated_root_changes(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& codes,
                                  float* raw, int64_t columns) {
  c10::InferenceMode inference;
  const auto changes =
      model.trajectory()->forward(normalized.to(at::kFloat), codes.to(normalized.device()).to(at::kFloat)).cpu().contiguous();
  const int64_t clips = changes.size(0), frames = changes.size(1);
  const float* change = changes.data_ptr<float>();
  // A rig's orientation is the decoded one (root_path.h, kHeadingMoves):
  // only the move is the network's.
  const int written = trajectory_frame_of(model.skeleton()) == TrajectoryFrame::kRootChanges ? 6 : 3;
  for (int64_t c = 0; c < clips; ++c) {
    for (int64_t f = 0; f < frames; ++f) {
      float* frame = raw + (c * frames + f) * columns;
      const float* before = change + (c * frames + f - 1) * 6;
      for (int a = 0; a < written; ++a) frame[a] = f == 0 ? 0.0f : before[a];
    }
  }
}

void write_generated_roots(const MotionManifold& model, const at::Tensor& normalized, const at::Tensor& codes,
                           std::vector<MotionFrames>& motions) {
  const int64_t columns = model.normalization().input_columns(), frames = normalized.size(1);
  std::vector<float> raw(static_cast<size_t>(normalized.size(0) * frames * columns));
  write_generated_root_changes(model, normalized, codes, raw.data(), columns);
  const TrajectoryFrame kind = trajectory_frame_of(model.skeleton());
  // Each motion's path on a thread of LibTorch's: a batch of 30 costs a
  // core's share of it.
  at::parallel_for(0, static_cast<int64_t>(motions.size()), 1, [&](int64_t begin, int64_t end) {
  for (int64_t i = begin; i < end; ++i) {
    MotionFrames& motion = motions[static_cast<size_t>(i)];
    for (int64_t f = 0; f < motion.frame_count() && f < frames; ++f) {
      std::memcpy(motion.frame(f), raw.data() + (i * frames + f) * columns, 3 * sizeof(float));
    }
    // The integrated vertical moves' errors add up: a sample's lowest foot
    // strayed more than 60 mm from the floor in up to 60% of its frames.
    // The feet's poses the floor is found from serve settling too: one pass
    // of forward kinematics over the legs.
    if (kind == TrajectoryFrame::kRootChanges) {
      settle_on_floor(integrate_level_root_path(model.skeleton(), motion, kRootRotationStepsPerFrame), motion);
    } else {
      RootPathIntegrator(kRootRotationStepsPerFrame, kind).integrate(motion);
      settle_on_floor(model.skeleton(), motion);
    }
  }
  });
}

}  // namespace mm
