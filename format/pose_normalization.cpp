#include "format/pose_normalization.h"

#include <cmath>

#include <nlohmann/json.hpp>

#include "format/input_error.h"
#include "format/json_text.h"

namespace mm {

namespace {

using nlohmann::json;

constexpr int kRootTranslationColumns = 3;
constexpr const char* kFormatName = "mm-pose-normalization";
constexpr int kFormatVersion = 1;

bool is_root_translation(int column) { return column < kRootTranslationColumns; }

}  // namespace

int PoseNormalization::input_columns() const { return static_cast<int>(mean.size()); }

int PoseNormalization::dims() const { return static_cast<int>(kept_columns.size()); }

PoseNormalization PoseNormalization::fit(const std::vector<const MotionFrames*>& sequences,
                                         double min_std, bool drop_root_translation) {
  int columns = -1;
  int64_t frames = 0;
  for (size_t s = 0; s < sequences.size(); ++s) {
    const MotionFrames* sequence = sequences[s];
    if (sequence == nullptr) {
      throw InputError("PoseNormalization::fit: sequence " + std::to_string(s) + " is null");
    }
    if (sequence->frame_count() == 0) continue;
    if (columns >= 0 && sequence->columns != columns) {
      throw InputError("PoseNormalization::fit: sequence " + std::to_string(s) + " has " +
                       std::to_string(sequence->columns) + " columns, expected " +
                       std::to_string(columns) + " like the ones before it");
    }
    columns = sequence->columns;
    frames += sequence->frame_count();
  }
  if (frames == 0) {
    throw InputError("PoseNormalization::fit: no frames in " + std::to_string(sequences.size()) +
                     " sequences, expected at least one frame");
  }
  if (drop_root_translation && columns < kRootTranslationColumns) {
    throw InputError("PoseNormalization::fit: " + std::to_string(columns) +
                     " columns cannot hold a root translation (expected >= 3)");
  }

  // Two passes in double: a one-pass sum of squares loses digits on columns
  // whose mean is large relative to their spread.
  std::vector<double> sum(static_cast<size_t>(columns), 0.0);
  for (const MotionFrames* sequence : sequences) {
    if (sequence->frame_count() == 0) continue;
    for (int64_t i = 0; i < sequence->frame_count(); ++i) {
      const float* row = sequence->frame(i);
      for (int c = 0; c < columns; ++c) sum[static_cast<size_t>(c)] += row[c];
    }
  }
  std::vector<double> mean(static_cast<size_t>(columns));
  for (int c = 0; c < columns; ++c) mean[static_cast<size_t>(c)] = sum[static_cast<size_t>(c)] / static_cast<double>(frames);
  std::vector<double> squares(static_cast<size_t>(columns), 0.0);
  for (const MotionFrames* sequence : sequences) {
    if (sequence->frame_count() == 0) continue;
    for (int64_t i = 0; i < sequence->frame_count(); ++i) {
      const float* row = sequence->frame(i);
      for (int c = 0; c < columns; ++c) {
        const double d = row[c] - mean[static_cast<size_t>(c)];
        squares[static_cast<size_t>(c)] += d * d;
      }
    }
  }

  PoseNormalization result;
  result.drop_root_translation = drop_root_translation;
  result.mean.resize(static_cast<size_t>(columns));
  result.stddev.resize(static_cast<size_t>(columns));
  for (int c = 0; c < columns; ++c) {
    const double stddev = std::sqrt(squares[static_cast<size_t>(c)] / static_cast<double>(frames));
    result.mean[static_cast<size_t>(c)] = static_cast<float>(mean[static_cast<size_t>(c)]);
    result.stddev[static_cast<size_t>(c)] = static_cast<float>(stddev);
    if (drop_root_translation && is_root_translation(c)) continue;
    if (stddev >= min_std) result.kept_columns.push_back(c);
  }
  if (result.kept_columns.empty()) {
    throw InputError("PoseNormalization::fit: no column has stddev >= " + std::to_string(min_std) +
                     " over " + std::to_string(frames) + " frames, expected at least one varying column");
  }
  return result;
}

void PoseNormalization::normalize(const float* frame, float* out) const {
  const size_t dims = kept_columns.size();
  for (size_t i = 0; i < dims; ++i) {
    const size_t c = static_cast<size_t>(kept_columns[i]);
    out[i] = (frame[c] - mean[c]) / stddev[c];
  }
}

void PoseNormalization::denormalize(const float* in, float* frame) const {
  const size_t columns = mean.size();
  for (size_t c = 0; c < columns; ++c) {
    frame[c] = (drop_root_translation && is_root_translation(static_cast<int>(c))) ? 0.0f : mean[c];
  }
  for (size_t i = 0; i < kept_columns.size(); ++i) {
    const size_t c = static_cast<size_t>(kept_columns[i]);
    frame[c] = in[i] * stddev[c] + mean[c];
  }
}

MotionFrames PoseNormalization::normalize(const MotionFrames& raw) const {
  if (raw.columns != input_columns()) {
    throw InputError("PoseNormalization::normalize: motion has " + std::to_string(raw.columns) +
                     " columns, expected " + std::to_string(input_columns()));
  }
  MotionFrames out;
  out.columns = dims();
  out.values.resize(static_cast<size_t>(raw.frame_count()) * kept_columns.size());
  for (int64_t i = 0; i < raw.frame_count(); ++i) normalize(raw.frame(i), out.frame(i));
  return out;
}

MotionFrames PoseNormalization::denormalize(const MotionFrames& normalized) const {
  if (normalized.columns != dims()) {
    throw InputError("PoseNormalization::denormalize: motion has " +
                     std::to_string(normalized.columns) + " columns, expected " +
                     std::to_string(dims()));
  }
  MotionFrames out;
  out.columns = input_columns();
  out.values.resize(static_cast<size_t>(normalized.frame_count()) * mean.size());
  for (int64_t i = 0; i < normalized.frame_count(); ++i) denormalize(normalized.frame(i), out.frame(i));
  return out;
}

std::string PoseNormalization::to_json_text() const {
  // Floats go through double, which nlohmann writes in shortest round-trip
  // form; reading back and narrowing to float restores the exact value.
  json document;
  document["format"] = kFormatName;
  document["version"] = kFormatVersion;
  document["mean"] = std::vector<double>(mean.begin(), mean.end());
  document["stddev"] = std::vector<double>(stddev.begin(), stddev.end());
  document["kept_columns"] = kept_columns;
  document["position_scale_mm"] = position_scale_mm;
  document["drop_root_translation"] = drop_root_translation;
  return document.dump();
}

namespace {

std::vector<float> float_array(const json& document, const char* field, const std::string& source) {
  if (!document.contains(field) || !document[field].is_array() || document[field].empty()) {
    throw InputError(source + ": field \"" + field + "\" is missing or not a non-empty array");
  }
  std::vector<float> values;
  values.reserve(document[field].size());
  for (size_t i = 0; i < document[field].size(); ++i) {
    const json& value = document[field][i];
    if (!value.is_number() || !std::isfinite(value.get<double>())) {
      throw InputError(source + ": field \"" + field + "\" element " + std::to_string(i) + " is " +
                       value.dump() + ", expected a finite number");
    }
    values.push_back(static_cast<float>(value.get<double>()));
  }
  return values;
}

}  // namespace

PoseNormalization PoseNormalization::from_json_text(const std::string& text,
                                                    const std::string& source_name) {
  const json document = parse_json_text(text, source_name);
  if (!document.is_object()) throw InputError(source_name + ": expected a JSON object");
  if (document.contains("format") && document["format"] != kFormatName) {
    throw InputError(source_name + ": field \"format\" is " + document["format"].dump() +
                     ", expected \"" + kFormatName + "\"");
  }
  if (document.contains("version") && document["version"] != kFormatVersion) {
    throw InputError(source_name + ": field \"version\" is " + document["version"].dump() +
                     ", expected " + std::to_string(kFormatVersion));
  }

  PoseNormalization result;
  result.mean = float_array(document, "mean", source_name);
  result.stddev = float_array(document, "stddev", source_name);
  if (result.stddev.size() != result.mean.size()) {
    throw InputError(source_name + ": field \"stddev\" has " + std::to_string(result.stddev.size()) +
                     " values, expected " + std::to_string(result.mean.size()) + " like \"mean\"");
  }
  if (document.contains("drop_root_translation")) {
    if (!document["drop_root_translation"].is_boolean()) {
      throw InputError(source_name + ": field \"drop_root_translation\" is " +
                       document["drop_root_translation"].dump() + ", expected true or false");
    }
    result.drop_root_translation = document["drop_root_translation"].get<bool>();
  }
  if (!document.contains("kept_columns") || !document["kept_columns"].is_array() ||
      document["kept_columns"].empty()) {
    throw InputError(source_name + ": field \"kept_columns\" is missing or not a non-empty array");
  }
  const json& kept = document["kept_columns"];
  for (size_t i = 0; i < kept.size(); ++i) {
    const std::string label = source_name + ": field \"kept_columns\" element " + std::to_string(i) +
                              " is " + kept[i].dump();
    if (!kept[i].is_number_integer()) throw InputError(label + ", expected an integer");
    const int64_t column = kept[i].get<int64_t>();
    if (column < 0 || column >= result.input_columns()) {
      throw InputError(label + ", expected a column in [0, " + std::to_string(result.input_columns()) + ")");
    }
    if (!result.kept_columns.empty() && column <= result.kept_columns.back()) {
      throw InputError(label + ", expected columns in strictly increasing order");
    }
    if (result.drop_root_translation && column < kRootTranslationColumns) {
      throw InputError(label + ", expected no root translation column (0..2) since "
                       "\"drop_root_translation\" is true");
    }
    if (!(result.stddev[static_cast<size_t>(column)] > 0.0f)) {
      throw InputError(label + ", but its stddev is " +
                       std::to_string(result.stddev[static_cast<size_t>(column)]) +
                       ", expected > 0 for a kept column");
    }
    result.kept_columns.push_back(static_cast<int>(column));
  }
  if (document.contains("position_scale_mm")) {
    const json& scale = document["position_scale_mm"];
    if (!scale.is_number() || !std::isfinite(scale.get<double>()) || scale.get<double>() <= 0.0) {
      throw InputError(source_name + ": field \"position_scale_mm\" is " + scale.dump() +
                       ", expected a finite number > 0");
    }
    result.position_scale_mm = scale.get<double>();
  }
  return result;
}

}  // namespace mm
