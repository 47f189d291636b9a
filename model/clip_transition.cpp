#include "model/clip_transition.h"

#include <cmath>
#include <limits>

#include "format/expmap_slerp.h"
#include "format/input_error.h"
#include "model/take_windows.h"

namespace mm {

const char* transition_method_name(TransitionMethod method) {
  return method == TransitionMethod::kCrossfade ? "crossfade" : "generated";
}

TransitionMethod parse_transition_method(const std::string& name, const std::string& field) {
  if (name == "generated") return TransitionMethod::kGenerated;
  if (name == "crossfade") return TransitionMethod::kCrossfade;
  throw InputError(field, "expected generated or crossfade, found '" + name + "'");
}

JoinedClips join_clips(const MotionManifold& model, const MotionFrames& a, const MotionFrames& b,
                       const TransitionOptions& options) {
  if (!(options.seconds >= kMinTransitionSeconds && options.seconds <= kMaxTransitionSeconds)) {
    throw InputError("transition_seconds", "expected " + std::to_string(kMinTransitionSeconds) + " to " +
                     std::to_string(kMaxTransitionSeconds) + " s, found " + std::to_string(options.seconds));
  }
  const int columns = model.normalization().input_columns();
  const auto n = static_cast<int64_t>(std::lround(options.seconds * kTakeModelRate));
  const auto context = static_cast<int64_t>(kTakeModelRate);
  for (const auto& [clip, name] : {std::pair<const MotionFrames*, const char*>{&a, "a"}, {&b, "b"}}) {
    if (clip->columns != columns) {
      throw InputError(std::string(name), "expected " + std::to_string(columns) + " values per frame, found " +
                       std::to_string(clip->columns));
    }
    if (clip->frame_count() < n + context) {
      throw InputError(std::string(name), "expected at least " + std::to_string(n + context) +
                       " frames at 25 Hz (the transition and 1 s more), found " + std::to_string(clip->frame_count()));
    }
  }
  const int64_t na = a.frame_count(), nb = b.frame_count();
  const int64_t window = model.config().frames;
  if (na + nb - n < window) {
    throw InputError("b", "expected the joined clips to make at least " + std::to_string(window) +
                     " frames at 25 Hz (one window of the model), found " + std::to_string(na + nb - n));
  }
  JoinedClips joined;
  joined.transition_first = na - n;
  joined.transition_last = na - 1;
  MotionFrames& out = joined.frames;
  out.columns = columns;
  out.values.assign(a.values.begin(), a.values.end() - n * columns);
  out.values.insert(out.values.end(), b.values.begin(), b.values.end());
  // The overlap: a's last n frames into b's first n. Weights from just
  // above 0 to just below 1, so that neither border frame repeats a clip's.
  const int joints = (columns - kRootTranslationValues) / 3;
  for (int64_t k = 0; k < n; ++k) {
    const double u = static_cast<double>(k + 1) / static_cast<double>(n + 1);
    const double w = u * u * (3 - 2 * u);
    const float* from = a.frame(na - n + k);
    const float* to = b.frame(k);
    float* frame = out.frame(na - n + k);
    for (int c = 0; c < kRootTranslationValues; ++c) frame[c] = static_cast<float>((1 - w) * from[c] + w * to[c]);
    for (int j = 0; j < joints; ++j) {
      const int column = kRootTranslationValues + 3 * j;
      if (options.method == TransitionMethod::kCrossfade) {
        slerp_expmap(from + column, to + column, w, frame + column);
      } else {
        std::fill_n(frame + column, 3, std::numeric_limits<float>::quiet_NaN());
      }
    }
  }
  if (options.method == TransitionMethod::kCrossfade) return joined;
  // The generated transition: the manifold's fill of a gap of every joint,
  // its code fitted to the clips' frames around it; fit_gap_codes writes
  // the gap's frames and two either side, which is all the matched fill
  // reads of it (the rest of `decoded` is the joined clips as they are).
  const MotionFrames fitted = fit_gap_codes(model, out, out, options.decoder, options.code_fit);
  GapFillOptions fill = options.fill;
  fill.method = GapMethod::kMatched;
  out = fill_gaps(out, &fitted, fill, kTakeModelRate);
  return joined;
}

}  // namespace mm
