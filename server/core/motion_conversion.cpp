#include "core/motion_conversion.h"

#include "format/foot_contacts.h"
#include "format/root_path.h"
#include "format/skeleton_bvh.h"

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

MotionFrames to_model_frames(const Motion& motion, const ModelShape& shape, const std::string& field) {
  if (motion.layout != shape.layout) {
    throw invalid(field + ".layout", "expected \"" + shape.layout + "\", found \"" + motion.layout + "\"");
  }
  if (motion.columns != shape.columns) {
    throw invalid(field + ".columns", "expected " + std::to_string(shape.columns) + " values per frame (" +
                                          shape.layout + "), found " + std::to_string(motion.columns));
  }
  int step = 0;
  if (motion.frame_rate == 25) {
    step = 1;
  } else if (motion.frame_rate == 50) {
    step = 2;
  } else {
    throw invalid(field + ".frame_rate", "expected 25 or 50 (Hz), found " + number(motion.frame_rate));
  }
  const int expected_frames = shape.frames * step;
  if (motion.frames != expected_frames) {
    throw invalid(field + ".frames", "expected " + std::to_string(expected_frames) + " frames at " +
                                         number(motion.frame_rate) + " Hz (" + std::to_string(shape.frames) +
                                         " at the model's 25 Hz), found " + std::to_string(motion.frames));
  }
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
  frames.values.reserve(static_cast<size_t>(shape.frames) * motion.columns);
  for (int f = 0; f < motion.frames; f += step) {
    const float* row = motion.values.data() + static_cast<size_t>(f) * motion.columns;
    frames.values.insert(frames.values.end(), row, row + motion.columns);
  }
  // A motion a reply gave in world layout goes back to the root the model
  // reads (the H3.6M layout's changes: two 50 Hz steps a 25 Hz frame).
  if (motion.root == "generated") model_root_from_world(shape.skeleton, frames, 2.0);
  return frames;
}

Motion to_wire_motion(const MotionFrames& frames, const ModelShape& shape, const std::string& root) {
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
