#include "model/trajectory_training.h"

#include <ATen/CPUGeneratorImpl.h>
#include <c10/core/InferenceMode.h>
#include <torch/optim/adam.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <nlohmann/json.hpp>
#include <random>

#include "format/input_error.h"
#include "format/root_path.h"

namespace mm {
namespace {

// Window starts, one entry per (motion, first frame) with `length` frames.
struct WindowPicker {
  std::vector<std::pair<size_t, int64_t>> starts;

  WindowPicker(const std::vector<MotionFrames>& motions, int64_t length) {
    for (size_t m = 0; m < motions.size(); ++m) {
      for (int64_t s = 0; s + length <= motions[m].frame_count(); ++s) starts.emplace_back(m, s);
    }
  }
};

// Raw windows (B, length, columns) at the given starts.
at::Tensor gather_windows(const std::vector<MotionFrames>& motions, const std::vector<std::pair<size_t, int64_t>>& picks,
                          int64_t length, int64_t columns) {
  auto raw = at::empty({static_cast<int64_t>(picks.size()), length, columns});
  for (size_t i = 0; i < picks.size(); ++i) {
    const auto& [m, start] = picks[i];
    std::memcpy(raw[static_cast<int64_t>(i)].data_ptr<float>(), motions[m].frame(start),
                sizeof(float) * static_cast<size_t>(length * columns));
  }
  return raw;
}

// What the network learns to write into columns 0..5 (root_path.h): the
// recorded root changes for kRootChanges; for kHeadingMoves the moves in
// the previous frame's heading axes and no turn (the orientation is the
// decoded pose's).
std::vector<MotionFrames> root_targets(const Skeleton& skeleton, const std::vector<MotionFrames>& motions) {
  std::vector<MotionFrames> targets;
  for (const MotionFrames& motion : motions) {
    MotionFrames target;
    target.columns = 6;
    target.values.reserve(static_cast<size_t>(motion.frame_count()) * 6);
    MotionFrames moves = motion;
    if (trajectory_frame_of(skeleton) == TrajectoryFrame::kHeadingMoves) {
      heading_moves_from_world(moves);
      for (int64_t f = 0; f < moves.frame_count(); ++f) std::fill(moves.frame(f) + 3, moves.frame(f) + 6, 0.0f);
    }
    for (int64_t f = 0; f < moves.frame_count(); ++f) target.values.insert(target.values.end(), moves.frame(f), moves.frame(f) + 6);
    targets.push_back(std::move(target));
  }
  return targets;
}

// Inputs (B, T, D) normalised and targets (B, T, 6): the root's change from
// each frame to the next.
std::pair<at::Tensor, at::Tensor> inputs_and_targets(const MotionManifold& model, const at::Tensor& raw,
                                                     const at::Tensor& raw_targets) {
  const int64_t frames = raw.size(1) - 1;
  auto poses = model.to_normalized(raw.narrow(1, 0, frames).to(model.device()));
  auto targets = raw_targets.narrow(1, 1, frames).to(model.device());
  return {poses, targets};
}

}  // namespace

TrajectoryTrainingReport train_root_trajectory(MotionManifold& model, const std::vector<MotionFrames>& motions,
                                               const TrajectoryTrainingOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  const int64_t frames = model.config().frames, length = frames + 1;
  const int64_t columns = model.normalization().input_columns();
  for (size_t m = 0; m < motions.size(); ++m) {
    if (motions[m].columns != columns) {
      throw InputError("motions[" + std::to_string(m) + "]: expected " + std::to_string(columns) +
                       " values per frame, found " + std::to_string(motions[m].columns));
    }
  }
  const WindowPicker picker(motions, length);
  if (picker.starts.empty()) {
    throw InputError("motions", "expected at least one motion of " + std::to_string(length) + " frames or more");
  }
  std::mt19937_64 random(options.seed);
  std::uniform_int_distribution<size_t> pick(0, picker.starts.size() - 1);
  const std::vector<MotionFrames> targets_of_motions = root_targets(model.skeleton(), motions);
  auto draw = [&](int count) {
    std::vector<std::pair<size_t, int64_t>> picks;
    for (int i = 0; i < count; ++i) picks.push_back(picker.starts[pick(random)]);
    return std::make_pair(gather_windows(motions, picks, length, columns),
                          gather_windows(targets_of_motions, picks, length, 6));
  };

  // A pool of windows, each as recorded and as the manifold reconstructs it,
  // with its code and its recorded root changes: what the network sees at
  // inference is the reconstruction and the code.
  model.train(false);
  std::vector<at::Tensor> recorded_parts, reconstructed_parts, code_parts, target_parts;
  for (int done = 0; done < options.windows; done += options.batch) {
    const int count = std::min(options.batch, options.windows - done);
    const auto [raw, raw_targets] = draw(count);
    auto [input, target] = inputs_and_targets(model, raw, raw_targets);
    c10::InferenceMode inference;
    auto code = model.encode(input);
    reconstructed_parts.push_back(model.decode(code, model.default_decoder()).clone());
    recorded_parts.push_back(input.clone());
    code_parts.push_back(code.clone());
    target_parts.push_back(target.clone());
  }
  const auto recorded = at::cat(recorded_parts).detach(), reconstructed = at::cat(reconstructed_parts).detach();
  const auto codes = at::cat(code_parts).detach(), targets_all = at::cat(target_parts).detach();
  const int64_t pool = recorded.size(0);

  torch::manual_seed(options.seed);
  RootTrajectory network(model.config().pose_dims, model.config().latent, options.shape);
  network->to(model.device());
  network->train(true);
  torch::optim::Adam optimizer(network->parameters(), torch::optim::AdamOptions(options.learning_rate));
  const double unit = kTrajectoryOutputMm;
  double loss_sum = 0, last_mean = 0;
  int loss_count = 0;
  std::uniform_int_distribution<int64_t> pick_window(0, pool - 1);
  for (int iteration = 1; iteration <= options.iterations; ++iteration) {
    // Half the batch reconstructed, half as recorded.
    std::vector<int64_t> rows;
    for (int i = 0; i < options.batch; ++i) rows.push_back(pick_window(random));
    const auto index = at::tensor(rows, at::kLong).to(model.device());
    const int64_t half = options.batch / 2;
    auto poses = at::cat({reconstructed.index_select(0, index.narrow(0, 0, half)),
                          recorded.index_select(0, index.narrow(0, half, options.batch - half))});
    auto targets = targets_all.index_select(0, index);
    auto predicted = network->forward(poses, codes.index_select(0, index));
    auto moves = predicted.narrow(2, 0, 3), true_moves = targets.narrow(2, 0, 3);
    auto turns = predicted.narrow(2, 3, 3), true_turns = targets.narrow(2, 3, 3);
    auto step_loss = (moves - true_moves).div(unit).pow(2).mean() +
                     (turns - true_turns).div(kTrajectoryOutputRadians).pow(2).mean();
    auto path_loss = (moves.cumsum(1) - true_moves.cumsum(1)).div(unit).pow(2).mean() / static_cast<double>(frames) +
                     (turns.cumsum(1) - true_turns.cumsum(1)).div(kTrajectoryOutputRadians).pow(2).mean() /
                         static_cast<double>(frames);
    auto loss = step_loss + 0.1 * path_loss;
    optimizer.zero_grad();
    loss.backward();
    optimizer.step();
    loss_sum += loss.item<double>();
    ++loss_count;
    if (iteration % 100 == 0 || iteration == options.iterations) {
      last_mean = loss_sum / loss_count;
      if (options.progress) options.progress(iteration, last_mean);
      loss_sum = 0;
      loss_count = 0;
    }
  }
  network->train(false);
  TrajectoryTrainingReport report;
  report.iterations = options.iterations;
  report.final_loss = last_mean;
  report.windows_available = static_cast<int64_t>(picker.starts.size());
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  const nlohmann::json training = {{"iterations", report.iterations},
                                   {"batch", options.batch},
                                   {"learning_rate", options.learning_rate},
                                   {"seed", options.seed},
                                   {"windows", pool},
                                   {"final_loss", report.final_loss},
                                   {"seconds", report.seconds},
                                   {"motions", motions.size()},
                                   {"windows_available", report.windows_available}};
  model.set_trajectory(network, training.dump());
  return report;
}

}  // namespace mm
