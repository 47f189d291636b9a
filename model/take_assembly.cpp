#include "model/take_assembly.h"

#include <algorithm>

#include "format/expmap_slerp.h"
#include "format/input_error.h"

namespace mm {

const char* take_blend_name(TakeBlend blend) { return blend == TakeBlend::kCrossfade ? "crossfade" : "cut"; }

TakeBlend parse_take_blend(const std::string& name) {
  if (name == "crossfade") return TakeBlend::kCrossfade;
  if (name == "cut") return TakeBlend::kCut;
  throw InputError("blend", "expected crossfade or cut, found '" + name + "'");
}

TakeAssembler::TakeAssembler(int columns, TakeBlend blend) : columns_(columns), blend_(blend) {
  if (columns < 3 || (columns - 3) % 3 != 0) {
    throw InputError("columns", "expected 3 root values and 3 per joint, found " + std::to_string(columns));
  }
  pending_.columns = columns;
}

void TakeAssembler::add(int64_t start, const MotionFrames& window, MotionFrames& out) {
  const int64_t end = assembled_frames();
  if (window.columns != columns_ || window.frame_count() < 1) {
    throw InputError("window", "expected at least one frame of " + std::to_string(columns_) + " values, found " +
                     std::to_string(window.frame_count()) + " frames of " + std::to_string(window.columns));
  }
  const bool first = last_start_ < 0;
  if (first ? start != 0 : (start < last_start_ || start > end)) {
    throw InputError("start", "expected " +
                     (first ? std::string("0 for the first window")
                            : std::to_string(last_start_) + " to " + std::to_string(end) +
                                  " (at or after the previous window's start, leaving no frame uncovered)") +
                     ", found " + std::to_string(start));
  }
  last_start_ = start;

  // Frames before this window's start are covered by no later window: final.
  const int64_t final_frames = start - first_pending_;
  out.values.insert(out.values.end(), pending_.values.begin(), pending_.values.begin() + final_frames * columns_);
  pending_.values.erase(pending_.values.begin(), pending_.values.begin() + final_frames * columns_);
  first_pending_ = start;

  const int64_t overlap = std::min(end - start, window.frame_count());
  if (blend_ == TakeBlend::kCrossfade) {
    for (int64_t t = 0; t < overlap; ++t) {
      const double w = static_cast<double>(t + 1) / static_cast<double>(overlap + 1);
      float* assembled = pending_.frame(t);
      const float* incoming = window.frame(t);
      for (int c = 0; c < 3; ++c) assembled[c] = static_cast<float>((1 - w) * assembled[c] + w * incoming[c]);
      for (int c = 3; c < columns_; c += 3) slerp_expmap(assembled + c, incoming + c, w, assembled + c);
    }
  } else {
    for (int64_t t = overlap / 2; t < overlap; ++t) std::copy_n(window.frame(t), columns_, pending_.frame(t));
  }
  pending_.values.insert(pending_.values.end(), window.values.begin() + overlap * columns_, window.values.end());
}

int64_t TakeAssembler::finish(MotionFrames& out) {
  out.values.insert(out.values.end(), pending_.values.begin(), pending_.values.end());
  first_pending_ += pending_.frame_count();
  pending_.values.clear();
  return first_pending_;
}

}  // namespace mm
