#include "model/trajectory_evaluation.h"

#include <cmath>

#include "format/input_error.h"

namespace mm {
namespace {

// The horizontal path (x, z) of a motion from the origin: frame 0's change
// is not part of it (it is the step into the clip).
std::vector<std::array<double, 2>> horizontal_path(const MotionFrames& motion) {
  std::vector<std::array<double, 2>> path(static_cast<size_t>(motion.frame_count()), {0.0, 0.0});
  for (int64_t f = 1; f < motion.frame_count(); ++f) {
    path[static_cast<size_t>(f)] = {path[static_cast<size_t>(f - 1)][0] + motion.frame(f)[0],
                                    path[static_cast<size_t>(f - 1)][1] + motion.frame(f)[2]};
  }
  return path;
}

double distance(const std::array<double, 2>& a, const std::array<double, 2>& b) {
  return std::hypot(a[0] - b[0], a[1] - b[1]);
}

}  // namespace

PathErrors compare_root_paths(const std::vector<MotionFrames>& recorded, const std::vector<MotionFrames>& predicted,
                              double rate_hz) {
  if (recorded.size() != predicted.size()) {
    throw InputError("predicted", "expected " + std::to_string(recorded.size()) + " motions, found " +
                     std::to_string(predicted.size()));
  }
  PathErrors errors;
  errors.clips = static_cast<int>(recorded.size());
  double distance_sum = 0, path_sum = 0, final_sum = 0, speed_sum = 0, heading_sum = 0;
  int64_t speed_frames = 0, heading_count = 0;
  const int64_t half_second = static_cast<int64_t>(std::lround(rate_hz / 2));
  for (size_t i = 0; i < recorded.size(); ++i) {
    const auto truth = horizontal_path(recorded[i]), guess = horizontal_path(predicted[i]);
    if (truth.size() != guess.size()) throw InputError("predicted[" + std::to_string(i) + "]: another frame count");
    if (truth.empty()) continue;
    double clip_path = 0;
    for (size_t f = 0; f < truth.size(); ++f) {
      clip_path += distance(truth[f], guess[f]);
      if (f > 0) {
        const double true_step = distance(truth[f], truth[f - 1]), guessed_step = distance(guess[f], guess[f - 1]);
        distance_sum += true_step;
        speed_sum += std::fabs(true_step - guessed_step) * rate_hz;
        ++speed_frames;
      }
    }
    path_sum += clip_path / static_cast<double>(truth.size());
    final_sum += distance(truth.back(), guess.back());
    for (size_t f = 0; f + static_cast<size_t>(half_second) < truth.size(); ++f) {
      const size_t g = f + static_cast<size_t>(half_second);
      const double tx = truth[g][0] - truth[f][0], tz = truth[g][1] - truth[f][1];
      const double gx = guess[g][0] - guess[f][0], gz = guess[g][1] - guess[f][1];
      if (std::hypot(tx, tz) < 50.0 || std::hypot(gx, gz) < 1e-6) continue;
      const double angle = std::atan2(tx * gz - tz * gx, tx * gx + tz * gz);
      heading_sum += std::fabs(angle) * 180.0 / M_PI;
      ++heading_count;
    }
  }
  if (errors.clips == 0) return errors;
  const double clips = static_cast<double>(errors.clips);
  errors.distance_mm = distance_sum / clips;
  errors.path_error_mm = path_sum / clips;
  errors.final_error_mm = final_sum / clips;
  errors.path_error_share = distance_sum > 0 ? path_sum / distance_sum : 0;
  errors.final_error_share = distance_sum > 0 ? final_sum / distance_sum : 0;
  errors.speed_error_mm_s = speed_frames > 0 ? speed_sum / static_cast<double>(speed_frames) : 0;
  if (heading_count > 0) errors.heading_error_deg = heading_sum / static_cast<double>(heading_count);
  return errors;
}

std::vector<MotionFrames> held_first_second_roots(const std::vector<MotionFrames>& recorded, double rate_hz) {
  std::vector<MotionFrames> held = recorded;
  const int64_t second = static_cast<int64_t>(std::lround(rate_hz));
  for (auto& motion : held) {
    const int64_t span = std::min<int64_t>(second, motion.frame_count() - 1);
    if (span < 1) continue;
    double x = 0, z = 0;
    for (int64_t f = 1; f <= span; ++f) {
      x += motion.frame(f)[0];
      z += motion.frame(f)[2];
    }
    for (int64_t f = 1; f < motion.frame_count(); ++f) {
      motion.frame(f)[0] = static_cast<float>(x / static_cast<double>(span));
      motion.frame(f)[2] = static_cast<float>(z / static_cast<double>(span));
    }
  }
  return held;
}

std::vector<MotionFrames> standing_roots(const std::vector<MotionFrames>& motions) {
  std::vector<MotionFrames> standing = motions;
  for (auto& motion : standing) {
    for (int64_t f = 0; f < motion.frame_count(); ++f) motion.frame(f)[0] = motion.frame(f)[2] = 0.0f;
  }
  return standing;
}

SkatingCount total_skating(const Skeleton& skeleton, const std::vector<MotionFrames>& motions, double rate_hz,
                           const FootContactThresholds& thresholds) {
  SkatingCount total;
  for (const auto& motion : motions) {
    const SkatingCount count = skating_ratio(skeleton, motion, rate_hz, thresholds);
    total.skating += count.skating;
    total.frames += count.frames;
  }
  return total;
}

}  // namespace mm
