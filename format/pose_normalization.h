// PoseNormalization: per-column statistics of the training poses that travel
// with a model, mapping raw frames (H3.6M: 99 values) to the standardised
// vectors the network sees (H3.6M: 51 values) and back.
//
// Columns that (almost) never change in the training data carry no
// information and would divide by ~0, so they are dropped; root translation
// (columns 0..2) is dropped because the model predicts body pose, not global
// position. Plain value type: const methods may be called concurrently.
#pragma once

#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

struct PoseNormalization {
  std::vector<float> mean;        // per input column (99 for H3.6M), raw units
  std::vector<float> stddev;      // per input column, population std, raw units
  std::vector<int> kept_columns;  // columns the network sees, increasing: stddev >= min_std
                                  // and not root translation (0..2); 51 for H3.6M
  double position_scale_mm = 1.0; // filled in by the model (FK-based); one scalar for all joints
  // Whether columns 0..2 were dropped as root translation; they then
  // denormalize to 0 instead of their mean.
  bool drop_root_translation = true;

  int input_columns() const;  // mean.size()
  int dims() const;           // kept_columns.size()

  // Fits over all frames of the given sequences (double accumulators,
  // population std). All sequences must have the same column count (>= 3 when
  // drop_root_translation). Throws InputError when there are no frames at all,
  // the column counts differ, a pointer is null, or no column varies.
  static PoseNormalization fit(const std::vector<const MotionFrames*>& sequences,
                               double min_std = 1e-4, bool drop_root_translation = true);

  // frame: input_columns() values -> out: dims() values, (x - mean) / stddev.
  // No checks (hot path); buffers must not overlap.
  void normalize(const float* frame, float* out) const;
  // in: dims() values -> frame: input_columns() values. Columns not kept get
  // their mean, except dropped root translation columns, which get 0.
  void denormalize(const float* in, float* frame) const;

  // Whole sequences. normalize requires raw.columns == input_columns() and
  // returns columns == dims(); denormalize is the inverse. Throw InputError
  // on a column-count mismatch.
  MotionFrames normalize(const MotionFrames& raw) const;
  MotionFrames denormalize(const MotionFrames& normalized) const;

  // JSON object {"format": "mm-pose-normalization", "version": 1, "mean": [...],
  // "stddev": [...], "kept_columns": [...], "position_scale_mm": s,
  // "drop_root_translation": b}; floats are written with round-trip precision,
  // so from_json_text(to_json_text()) is exact.
  std::string to_json_text() const;
  // Parses and validates: mean/stddev non-empty, equal length and finite;
  // kept_columns non-empty, strictly increasing, in range, with stddev > 0
  // and excluding 0..2 when drop_root_translation; position_scale_mm finite
  // and > 0. Throws InputError naming `source_name` and the field.
  static PoseNormalization from_json_text(const std::string& text, const std::string& source_name);
};

}  // namespace mm
