#include "model/transition_evaluation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>

#include "format/foot_contacts.h"
#include "format/input_error.h"
#include "model/take_processor.h"
#include "model/take_windows.h"

namespace mm {
namespace {

constexpr double kRate = kTakeModelRate;
constexpr int kMethods = 2;
const TransitionMethod kMethodOrder[kMethods] = {TransitionMethod::kCrossfade, TransitionMethod::kGenerated};

double distance(const Vec3& a, const Vec3& b) {
  return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
}

// A frame's joint positions about the root with the root's rotation removed.
std::vector<Vec3> unturned_pose(const Skeleton& skeleton, const float* frame, int columns) {
  std::vector<float> copy(frame, frame + columns);
  std::fill_n(copy.begin() + kRootTranslationValues, 3, 0.0f);
  return pose_positions(skeleton, copy.data());
}

double mean_joint_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  double sum = 0;
  for (size_t j = 1; j < a.size(); ++j) sum += distance(a[j], b[j]);
  return sum / static_cast<double>(std::max<size_t>(1, a.size() - 1));
}

// Mean over the joints but the root of the move between two frames, the
// root at the origin.
double pose_move(const Skeleton& skeleton, const float* a, const float* b) {
  return mean_joint_distance(pose_positions(skeleton, a), pose_positions(skeleton, b));
}

struct Sums {
  int64_t transitions = 0;
  double jump_mm = 0, jump_ratio = 0, manifold_distance = 0, recorded_distance = 0;
  SkatingCount skating;
  nlohmann::json json() const {
    const double n = std::max<double>(1, static_cast<double>(transitions));
    return {{"transitions", transitions},
            {"border_jump_mm", jump_mm / n},
            {"border_jump_ratio", jump_ratio / n},
            {"skating_ratio", skating.ratio()},
            {"distance_from_reconstructions_mm", manifold_distance / n},
            {"recorded_distance_from_reconstructions_mm", recorded_distance / n}};
  }
};

std::string number(double value, const char* format = "%.1f") {
  char text[32];
  std::snprintf(text, sizeof text, format, value);
  return text;
}

}  // namespace

GapBenchmarkResult run_transition_benchmark(const MotionManifold& model, const std::vector<GapBenchmarkTake>& takes,
                                            const TransitionBenchmarkOptions& options) {
  const Skeleton& skeleton = model.skeleton();
  const auto clip_frames = static_cast<int64_t>(std::lround(options.clip_seconds * kRate));
  std::vector<const GapBenchmarkTake*> usable;
  for (const auto& take : takes) {
    if (take.frames.frame_count() >= std::max<int64_t>(clip_frames, model.config().frames)) usable.push_back(&take);
  }
  if (usable.size() < 2) throw InputError("takes", "expected at least two takes of a clip's length, found " + std::to_string(usable.size()));

  // The poses the manifold gives back of real motion: each take
  // reconstructed, every 5th frame.
  std::vector<std::vector<Vec3>> bank;
  for (const auto* take : usable) {
    TakeOptions reconstruct;
    reconstruct.operation = TakeOperation::kReconstruct;
    reconstruct.frame_rate = kRate;
    reconstruct.at_model_rate = true;
    reconstruct.decoder = options.decoder;
    const TakeResult result = process_take(model, take->frames, reconstruct);
    for (int64_t f = 0; f < result.frames.frame_count(); f += 5) {
      bank.push_back(unturned_pose(skeleton, result.frames.frame(f), result.frames.columns));
    }
  }
  auto nearest = [&](const float* frame, int columns) {
    const auto pose = unturned_pose(skeleton, frame, columns);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& other : bank) best = std::min(best, mean_joint_distance(pose, other));
    return best;
  };

  std::mt19937_64 engine(options.seed);
  std::vector<std::array<Sums, kMethods>> overall(options.seconds.size());
  const size_t n = usable.size();
  for (size_t i = 0; i < n; ++i) {
    const GapBenchmarkTake& ta = *usable[i];
    const GapBenchmarkTake& tb = *usable[(i + n / 2) % n];
    auto cut = [&](const MotionFrames& frames) {
      std::uniform_int_distribution<int64_t> at(0, frames.frame_count() - clip_frames);
      const int64_t start = at(engine);
      MotionFrames clip;
      clip.columns = frames.columns;
      clip.values.assign(frames.frame(start), frames.frame(start) + clip_frames * frames.columns);
      return clip;
    };
    const MotionFrames a = cut(ta.frames), b = cut(tb.frames);
    // The recorded clips' median move and their distance from the bank.
    std::vector<double> moves;
    for (const MotionFrames* clip : {&a, &b}) {
      for (int64_t f = 1; f < clip->frame_count(); ++f) moves.push_back(pose_move(skeleton, clip->frame(f - 1), clip->frame(f)));
    }
    std::nth_element(moves.begin(), moves.begin() + static_cast<std::ptrdiff_t>(moves.size() / 2), moves.end());
    const double median_move = std::max(moves[moves.size() / 2], 1e-6);
    for (size_t s = 0; s < options.seconds.size(); ++s) {
      const auto length = static_cast<int64_t>(std::lround(options.seconds[s] * kRate));
      double recorded = 0;
      for (int64_t k = 0; k < length; ++k) {
        recorded += nearest(k % 2 == 0 ? a.frame(a.frame_count() - length + k) : b.frame(k), a.columns);
      }
      recorded /= static_cast<double>(length);
      for (int m = 0; m < kMethods; ++m) {
        TransitionOptions transition;
        transition.seconds = options.seconds[s];
        transition.method = kMethodOrder[m];
        transition.decoder = options.decoder;
        transition.fill = options.fill;
        transition.code_fit = options.code_fit;
        const JoinedClips joined = join_clips(model, a, b, transition);
        const MotionFrames& out = joined.frames;
        Sums sums;
        sums.transitions = 1;
        const int64_t first = joined.transition_first, last = joined.transition_last;
        sums.jump_mm = std::max(pose_move(skeleton, out.frame(first - 1), out.frame(first)),
                                pose_move(skeleton, out.frame(last), out.frame(last + 1)));
        sums.jump_ratio = sums.jump_mm / median_move;
        double away = 0;
        for (int64_t f = first; f <= last; ++f) away += nearest(out.frame(f), out.columns);
        sums.manifold_distance = away / static_cast<double>(length);
        sums.recorded_distance = recorded;
        MotionFrames around;
        around.columns = out.columns;
        const int64_t from = std::max<int64_t>(0, first - static_cast<int64_t>(kRate));
        const int64_t to = std::min<int64_t>(out.frame_count() - 1, last + static_cast<int64_t>(kRate));
        around.values.assign(out.frame(from), out.frame(to) + out.columns);
        sums.skating = skating_ratio(skeleton, around, kRate);
        auto& total = overall[s][static_cast<size_t>(m)];
        total.transitions += 1;
        total.jump_mm += sums.jump_mm;
        total.jump_ratio += sums.jump_ratio;
        total.manifold_distance += sums.manifold_distance;
        total.recorded_distance += sums.recorded_distance;
        total.skating.skating += sums.skating.skating;
        total.skating.frames += sums.skating.frames;
      }
    }
  }

  nlohmann::json rows = nlohmann::json::array();
  std::string md =
      "\nTransitions between clips of two takes of different actions (" + std::to_string(n) + " pairs of " +
      number(options.clip_seconds, "%.0f") +
      " s clips): border jump over the clips' median move, foot-skating ratio of the transition with 1 s each side, "
      "and the transition's poses' distance from the nearest pose of the manifold's reconstructions of the S5 takes "
      "(mm; the clips' own recorded frames beside it for scale):\n\n"
      "| transition (s) | jump: crossfade | jump: generated | skating: crossfade | skating: generated | distance: "
      "crossfade | distance: generated | distance: recorded |\n|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (size_t s = 0; s < options.seconds.size(); ++s) {
    nlohmann::json methods = nlohmann::json::object();
    for (int m = 0; m < kMethods; ++m) methods[transition_method_name(kMethodOrder[m])] = overall[s][static_cast<size_t>(m)].json();
    rows.push_back({{"transition_seconds", options.seconds[s]}, {"methods", methods}});
    const auto c = overall[s][0].json(), g = overall[s][1].json();
    md += "| " + number(options.seconds[s]) + " | " + number(c["border_jump_ratio"].get<double>(), "%.2f") + " | " +
          number(g["border_jump_ratio"].get<double>(), "%.2f") + " | " + number(c["skating_ratio"].get<double>(), "%.3f") +
          " | " + number(g["skating_ratio"].get<double>(), "%.3f") + " | " +
          number(c["distance_from_reconstructions_mm"].get<double>()) + " | " +
          number(g["distance_from_reconstructions_mm"].get<double>()) + " | " +
          number(c["recorded_distance_from_reconstructions_mm"].get<double>()) + " |\n";
  }
  nlohmann::json document = {{"pairs", n},
                             {"clip_seconds", options.clip_seconds},
                             {"seed", options.seed},
                             {"rate_hz", kRate},
                             {"decoder", decoder_name(options.decoder)},
                             {"bank_poses", bank.size()},
                             {"transitions", rows}};
  return {document.dump(2) + "\n", md};
}

}  // namespace mm
