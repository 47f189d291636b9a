#include "format/motion_text.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <iterator>
#include <ostream>
#include <sstream>

#include "format/atomic_file.h"
#include "format/input_error.h"

namespace mm {

int64_t MotionFrames::frame_count() const {
  return columns > 0 ? static_cast<int64_t>(values.size()) / columns : 0;
}

const float* MotionFrames::frame(int64_t i) const { return values.data() + i * columns; }

float* MotionFrames::frame(int64_t i) { return values.data() + i * columns; }

namespace {

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::string location(const std::string& source, int64_t line) {
  return source + ":" + std::to_string(line) + ": ";
}

// Quotes a field for an error message, shortened so a garbage line (e.g. a
// binary file) does not produce a megabyte-long message.
std::string quoted(const char* begin, const char* end) {
  constexpr ptrdiff_t kMaxShown = 40;
  std::string text(begin, std::min(end, begin + kMaxShown));
  if (end - begin > kMaxShown) text += "...";
  return "\"" + text + "\"";
}

void check_columns(int expected_columns, const std::string& source_name) {
  if (expected_columns <= 0) {
    throw InputError(source_name + ": expected column count must be positive, got " +
                     std::to_string(expected_columns));
  }
}

}  // namespace

MotionFrames parse_motion_text_buffer(const char* data, size_t size,
                                      const std::string& source_name, int expected_columns) {
  check_columns(expected_columns, source_name);
  MotionFrames motion;
  motion.columns = expected_columns;
  // Reserve from a size estimate (~10.7 bytes per value in the data set) to
  // avoid repeated growth on 4 MB files.
  motion.values.reserve(size / 10 + static_cast<size_t>(expected_columns));

  const char* const end = data + size;
  const char* line_begin = data;
  // Editors on Windows start UTF-8 text with a byte-order mark; it carries no
  // data, and refusing it would reject an otherwise valid file.
  static constexpr char kByteOrderMark[] = "\xEF\xBB\xBF";
  if (size >= 3 && std::memcmp(data, kByteOrderMark, 3) == 0) line_begin += 3;
  int64_t line_number = 0;
  int64_t first_blank_line = 0;  // 0: none seen yet
  while (line_begin < end) {
    ++line_number;
    const char* line_end =
        static_cast<const char*>(std::memchr(line_begin, '\n', static_cast<size_t>(end - line_begin)));
    if (line_end == nullptr) line_end = end;
    const char* next_line = line_end < end ? line_end + 1 : end;
    const char* content_end = line_end;
    while (content_end > line_begin && is_blank(content_end[-1])) --content_end;
    const char* content_begin = line_begin;
    while (content_begin < content_end && is_blank(*content_begin)) ++content_begin;

    if (content_begin == content_end) {
      if (first_blank_line == 0) first_blank_line = line_number;
      line_begin = next_line;
      continue;
    }
    if (first_blank_line != 0) {
      // A hole in the middle of a sequence would silently join two motions.
      throw InputError(location(source_name, first_blank_line) +
                       "blank line, expected " + std::to_string(expected_columns) +
                       " values (blank lines are allowed only at the end)");
    }

    const int64_t found = std::count(content_begin, content_end, ',') + 1;
    if (found != expected_columns) {
      throw InputError(location(source_name, line_number) + "expected " +
                       std::to_string(expected_columns) + " values, found " +
                       std::to_string(found));
    }
    const char* field = content_begin;
    for (int column = 0; column < expected_columns; ++column) {
      const char* field_end = static_cast<const char*>(
          std::memchr(field, ',', static_cast<size_t>(content_end - field)));
      if (field_end == nullptr) field_end = content_end;
      const char* value_begin = field;
      const char* value_end = field_end;
      while (value_begin < value_end && is_blank(*value_begin)) ++value_begin;
      while (value_end > value_begin && is_blank(value_end[-1])) --value_end;
      // from_chars rejects a leading '+', which some writers emit.
      const char* number_begin =
          (value_begin < value_end && *value_begin == '+') ? value_begin + 1 : value_begin;

      float value = 0.0f;
      const auto [parsed_end, error] = std::from_chars(number_begin, value_end, value);
      if (error == std::errc::result_out_of_range) {
        throw InputError(location(source_name, line_number) + "value " +
                         std::to_string(column + 1) + " " + quoted(value_begin, value_end) +
                         " is out of the range of a 32-bit float");
      }
      if (error != std::errc() || parsed_end != value_end || number_begin == value_end) {
        throw InputError(location(source_name, line_number) + "value " +
                         std::to_string(column + 1) + " " + quoted(value_begin, value_end) +
                         " is not a number, expected a decimal number");
      }
      if (!std::isfinite(value)) {
        throw InputError(location(source_name, line_number) + "value " +
                         std::to_string(column + 1) + " " + quoted(value_begin, value_end) +
                         " is not finite, expected a finite number");
      }
      const bool translation = column < kRootTranslationValues;
      const double bound = translation ? kMaxRootTranslationMm : kMaxRotationRadians;
      if (std::fabs(value) > bound) {
        std::ostringstream limit;
        limit << bound;
        throw InputError(location(source_name, line_number) + "value " + std::to_string(column + 1) + " " +
                         quoted(value_begin, value_end) + " is out of range, expected " +
                         (translation ? "a root translation within +-" + limit.str() + " mm"
                                      : "an exponential-map rotation within +-" + limit.str() + " radians"));
      }
      motion.values.push_back(value);
      field = field_end + 1;
    }
    line_begin = next_line;
  }
  if (motion.values.empty()) {
    throw InputError(location(source_name, 1) + "no frames (empty file), expected lines of " +
                     std::to_string(expected_columns) + " comma-separated values");
  }
  return motion;
}

MotionFrames parse_motion_text(std::istream& in, const std::string& source_name,
                               int expected_columns) {
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(source_name + ": read error");
  return parse_motion_text_buffer(text.data(), text.size(), source_name, expected_columns);
}

MotionFrames read_motion_text(const std::string& path, int expected_columns) {
  const std::string text = read_whole_file(path);
  return parse_motion_text_buffer(text.data(), text.size(), path, expected_columns);
}

namespace {

void append_motion_text(const MotionFrames& motion, std::string& text) {
  // "-1234567.1234567" plus separator fits easily; to_chars avoids locale
  // dependence (a ',' decimal separator would corrupt the format).
  char buffer[64];
  const int64_t frames = motion.frame_count();
  text.reserve(text.size() + static_cast<size_t>(frames * motion.columns) * 11);
  for (int64_t i = 0; i < frames; ++i) {
    const float* row = motion.frame(i);
    for (int c = 0; c < motion.columns; ++c) {
      const auto result = std::to_chars(buffer, buffer + sizeof(buffer), row[c],
                                        std::chars_format::fixed, 7);
      if (c > 0) text.push_back(',');
      text.append(buffer, result.ptr);
    }
    text.push_back('\n');
  }
}

}  // namespace

void write_motion_text(const MotionFrames& motion, std::ostream& out) {
  std::string text;
  append_motion_text(motion, text);
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  if (!out) throw std::runtime_error("write_motion_text: output stream failed");
}

void write_motion_text_file(const MotionFrames& motion, const std::string& path) {
  std::string text;
  append_motion_text(motion, text);
  write_file_atomically(path, text);
}

std::vector<MotionFrames> split_phases(const MotionFrames& motion, int factor) {
  if (factor < 1) {
    throw InputError("split_phases: factor " + std::to_string(factor) +
                     " is invalid, expected an integer >= 1");
  }
  const int64_t frames = motion.frame_count();
  std::vector<MotionFrames> phases(static_cast<size_t>(factor));
  for (int k = 0; k < factor; ++k) {
    MotionFrames& phase = phases[static_cast<size_t>(k)];
    phase.columns = motion.columns;
    if (frames > k) phase.values.reserve(static_cast<size_t>((frames - k + factor - 1) / factor) * motion.columns);
    for (int64_t i = k; i < frames; i += factor) {
      phase.values.insert(phase.values.end(), motion.frame(i), motion.frame(i) + motion.columns);
    }
  }
  return phases;
}

}  // namespace mm
