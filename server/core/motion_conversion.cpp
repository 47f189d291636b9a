#include "server/core/motion_conversion.h"

#include "format/foot_contacts.h"
#include "format/motion_text.h"
#include "format/root_path.h"
#include "format/skeleton_bvh.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mm::service {
namespace {

// The tool's bound on code values (model/tool): far beyond anything the
// prior (N(0, I)) or an encoder produces, near enough to refuse garbage.
constexpr double kMaxCodeMagnitude = 1e3;

ApiError invalid(const std::string& field, const std::string& message) {
  return ApiError(ErrorCode::kInvalidArgument, field, message);
}

std::string number(double value) {
  if (std::isnan(value)) return "NaN";
  if (std::isinf(value)) return value > 0 ? "Infinity" : "-Infinity";
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

}  // namespace

std::string layout_name(int columns) {
  return columns == kH36mColumns ? std::string(kH36mLayout) : "expmap-" + std::to_string(columns);
}

namespace {

// The layout and columns checked; the step that takes the motion's rate to
// 25 Hz (1 or 2).
int checked_rate_step(const Motion& motion, const ModelShape& shape, const std::string& field) {
  if (motion.layout != shape.layout) {
    throw invalid(field + ".layout", "expected \"" + shape.layout + "\", found \"" + motion.layout + "\"");
  }
  if (motion.columns != shape.columns) {
    throw invalid(field + ".columns", "expected " + std::to_string(shape.columns) + " values per frame (" +
                                          shape.layout + "), found " + std::to_string(motion.columns));
  }
  if (motion.frame_rate == 25) return 1;
  if (motion.frame_rate == 50) return 2;
  throw invalid(field + ".frame_rate", "expected 25 or 50 (Hz), found " + number(motion.frame_rate));
}

// The values checked and every `step`-th frame kept, the root brought back
// to the model's (the frame count already checked).
MotionFrames checked_frames(const Motion& motion, const ModelShape& shape, const std::string& field, int step) {
  const size_t expected_values = static_cast<size_t>(motion.frames) * static_cast<size_t>(motion.columns);
  if (motion.values.size() != expected_values) {
    throw invalid(field + ".values", "expected frames x columns = " + std::to_string(expected_values) +
                                         " values, found " + std::to_string(motion.values.size()));
  }
  for (size_t i = 0; i < motion.values.size(); ++i) {
    const double value = motion.values[i];
    const bool translation = static_cast<int>(i % motion.columns) < kRootTranslationValues;
    const double bound = translation ? kMaxRootTranslationMm : kMaxRotationRadians;
    if (!std::isfinite(value) || std::fabs(value) > bound) {
      throw invalid(field + ".values[" + std::to_string(i) + "]",
                    "expected a finite " + std::string(translation ? "root translation within +-1e5 mm"
                                                                   : "exponential-map value within +-1e3 rad") +
                        " (frame " + std::to_string(i / motion.columns) + ", column " +
                        std::to_string(i % motion.columns) + "), found " + number(value));
    }
  }
  MotionFrames frames;
  frames.columns = motion.columns;
  frames.values.reserve(static_cast<size_t>((motion.frames + step - 1) / step) * motion.columns);
  for (int f = 0; f < motion.frames; f += step) {
    const float* row = motion.values.data() + static_cast<size_t>(f) * motion.columns;
    frames.values.insert(frames.values.end(), row, row + motion.columns);
  }
  // A motion a reply gave in world layout goes back to the root the model
  // reads (the H3.6M layout's changes: two 50 Hz steps a 25 Hz frame).
  if (motion.root == "generated") model_root_from_world(shape.skeleton, frames, 2.0);
  return frames;
}

}  // namespace

MotionFrames to_model_frames(const Motion& motion, const ModelShape& shape, const std::string& field) {
  const int step = checked_rate_step(motion, shape, field);
  const int expected_frames = shape.frames * step;
  if (motion.frames != expected_frames) {
    throw invalid(field + ".frames", "expected " + std::to_string(expected_frames) + " frames at " +
                                         number(motion.frame_rate) + " Hz (" + std::to_string(shape.frames) +
                                         " at the model's 25 Hz), found " + std::to_string(motion.frames));
  }
  return checked_frames(motion, shape, field, step);
}

MotionFrames clip_to_model_frames(const Motion& motion, const ModelShape& shape, const std::string& field,
                                  int64_t min_frames, const std::string& min_why, int64_t max_frames,
                                  const std::string& max_option) {
  const int step = checked_rate_step(motion, shape, field);
  const int64_t at_model_rate = (static_cast<int64_t>(std::max(motion.frames, 0)) + step - 1) / step;
  if (at_model_rate > max_frames) {
    throw ApiError(ErrorCode::kResourceExhausted, field + ".frames",
                   "at most " + std::to_string(max_frames) + " frames at 25 Hz allowed (the server's " + max_option +
                       "), found " + std::to_string(motion.frames) + " at " + number(motion.frame_rate) + " Hz",
                   /*too_large=*/true);
  }
  if (at_model_rate < min_frames) {
    throw invalid(field + ".frames", "expected at least " + std::to_string(min_frames) + " frames at 25 Hz (" +
                                         min_why + "), found " + std::to_string(motion.frames) + " at " +
                                         number(motion.frame_rate) + " Hz");
  }
  return checked_frames(motion, shape, field, step);
}

Motion to_api_motion(const MotionFrames& frames, const ModelShape& shape, const std::string& root) {
  Motion motion;
  motion.frames = static_cast<int>(frames.frame_count());
  motion.columns = frames.columns;
  motion.frame_rate = 25;
  motion.layout = shape.layout;
  motion.values = frames.values;
  motion.root = root;
  if (frames.columns == skeleton_motion_columns(shape.skeleton)) {
    for (const uint8_t planted : foot_contacts(shape.skeleton, frames, 25)) motion.contacts.push_back(planted);
  }
  return motion;
}

void check_code(const Code& code, const ModelShape& shape, const std::string& field) {
  if (static_cast<int>(code.size()) != shape.latent) {
    throw invalid(field, "expected a code of " + std::to_string(shape.latent) + " values, found " +
                             std::to_string(code.size()));
  }
  for (size_t i = 0; i < code.size(); ++i) {
    if (!std::isfinite(code[i]) || std::fabs(code[i]) > kMaxCodeMagnitude) {
      throw invalid(field + "[" + std::to_string(i) + "]",
                    "expected a finite value within +-1e3, found " + number(code[i]));
    }
  }
}

}  // namespace mm::service
