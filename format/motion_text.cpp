#include "format/motion_text.h"
#include "format/motion_text_rows.h"

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

// A row: a non-blank line's content without the blanks around it.
struct TextRow {
  const char* begin;
  const char* end;
  int64_t line;
};

// Calls visit(row) for each row in order until it returns false. A blank
// line followed by a row is refused: a hole in the middle of a sequence
// would silently join two motions. `expected_columns` is for that message
// (0: unknown).
template <typename Visit>
void for_each_row(const char* data, size_t size, const std::string& source_name, int expected_columns,
                  Visit visit) {
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
    line_begin = next_line;

    if (content_begin == content_end) {
      if (first_blank_line == 0) first_blank_line = line_number;
      continue;
    }
    if (first_blank_line != 0) {
      throw InputError(location(source_name, first_blank_line) + "blank line, expected " +
                       (expected_columns > 0 ? std::to_string(expected_columns) + " values" : "a row of values") +
                       " (blank lines are allowed only at the end)");
    }
    if (!visit(TextRow{content_begin, content_end, line_number})) return;
  }
}

void check_value_count(const TextRow& row, const std::string& source_name, int expected_columns) {
  const int64_t found = std::count(row.begin, row.end, ',') + 1;
  if (found != expected_columns) {
    throw InputError(location(source_name, row.line) + "expected " + std::to_string(expected_columns) +
                     " values, found " + std::to_string(found));
  }
}

// The row's values appended to `out`, each checked.
// `nan_is_missing`: NaN is taken in the joint columns (a missing value).
void parse_row(const TextRow& row, const std::string& source_name, int expected_columns, std::vector<float>& out,
               bool nan_is_missing = false) {
  const int64_t line_number = row.line;
  check_value_count(row, source_name, expected_columns);
  const char* field = row.begin;
  for (int column = 0; column < expected_columns; ++column) {
    const char* field_end =
        static_cast<const char*>(std::memchr(field, ',', static_cast<size_t>(row.end - field)));
    if (field_end == nullptr) field_end = row.end;
    const char* value_begin = field;
    const char* value_end = field_end;
    while (value_begin < value_end && is_blank(*value_begin)) ++value_begin;
    while (value_end > value_begin && is_blank(value_end[-1])) --value_end;
    // from_chars rejects a leading '+', which some writers emit.
    const char* number_begin = (value_begin < value_end && *value_begin == '+') ? value_begin + 1 : value_begin;

    float value = 0.0f;
    const auto [parsed_end, error] = std::from_chars(number_begin, value_end, value);
    if (error == std::errc::result_out_of_range) {
      throw InputError(location(source_name, line_number) + "value " + std::to_string(column + 1) + " " +
                       quoted(value_begin, value_end) + " is out of the range of a 32-bit float");
    }
    if (error != std::errc() || parsed_end != value_end || number_begin == value_end) {
      throw InputError(location(source_name, line_number) + "value " + std::to_string(column + 1) + " " +
                       quoted(value_begin, value_end) + " is not a number, expected a decimal number");
    }
    if (std::isnan(value) && nan_is_missing && column >= kRootTranslationValues) {
      out.push_back(value);
      field = field_end + 1;
      continue;
    }
    if (!std::isfinite(value)) {
      throw InputError(location(source_name, line_number) + "value " + std::to_string(column + 1) + " " +
                       quoted(value_begin, value_end) + " is not finite, expected a finite number" +
                       (nan_is_missing ? " (NaN marks a missing joint value, not a root translation)" : ""));
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
    out.push_back(value);
    field = field_end + 1;
  }
}

[[noreturn]] void no_frames(const std::string& source_name, int expected_columns) {
  throw InputError(location(source_name, 1) + "no frames (empty file), expected lines of " +
                   (expected_columns > 0 ? std::to_string(expected_columns) + " " : "") + "comma-separated values");
}

}  // namespace

MotionFrames parse_motion_text_buffer(const char* data, size_t size,
                                      const std::string& source_name, int expected_columns) {
  return parse_motion_text_buffer(data, size, source_name, expected_columns, false);
}

MotionFrames parse_motion_text_buffer(const char* data, size_t size, const std::string& source_name,
                                      int expected_columns, bool nan_is_missing) {
  check_columns(expected_columns, source_name);
  MotionFrames motion;
  motion.columns = expected_columns;
  // Reserve from a size estimate (~10.7 bytes per value in the data set) to
  // avoid repeated growth on 4 MB files.
  motion.values.reserve(size / 10 + static_cast<size_t>(expected_columns));
  for_each_row(data, size, source_name, expected_columns, [&](const TextRow& row) {
    parse_row(row, source_name, expected_columns, motion.values, nan_is_missing);
    return true;
  });
  if (motion.values.empty()) no_frames(source_name, expected_columns);
  return motion;
}

int64_t count_motion_text_rows(const char* data, size_t size, const std::string& source_name, int expected_columns,
                               int64_t max_rows) {
  check_columns(expected_columns, source_name);
  int64_t rows = 0;
  for_each_row(data, size, source_name, expected_columns, [&](const TextRow& row) {
    check_value_count(row, source_name, expected_columns);
    if (++rows > max_rows) {
      throw InputError(location(source_name, row.line) + "more than " + std::to_string(max_rows) +
                       " rows, the most a motion text may hold (" +
                       (max_rows == kMaxMotionTextRows ? "11.1 h at 50 Hz" : "the limit here") + ")");
    }
    return true;
  });
  if (rows == 0) no_frames(source_name, expected_columns);
  return rows;
}

MotionFrames parse_motion_text_rows(const char* data, size_t size, const std::string& source_name,
                                    int expected_columns, int64_t first_row, int64_t row_count,
                                    bool nan_is_missing) {
  check_columns(expected_columns, source_name);
  MotionFrames motion;
  motion.columns = expected_columns;
  if (first_row < 0 || row_count < 0) {
    throw InputError(source_name + ": rows from " + std::to_string(first_row) + ", " + std::to_string(row_count) +
                     " of them: expected a row and a count that are not negative");
  }
  motion.values.reserve(static_cast<size_t>(row_count) * static_cast<size_t>(expected_columns));
  int64_t row_index = 0;
  for_each_row(data, size, source_name, expected_columns, [&](const TextRow& row) {
    if (row_index >= first_row) parse_row(row, source_name, expected_columns, motion.values, nan_is_missing);
    return ++row_index < first_row + row_count;
  });
  if (motion.frame_count() < row_count) {
    if (row_index == 0) no_frames(source_name, expected_columns);
    throw InputError(source_name + ": " + std::to_string(row_index) + " rows, fewer than the " +
                     std::to_string(first_row + row_count) + " that rows " + std::to_string(first_row) + " to " +
                     std::to_string(first_row + row_count - 1) + " need");
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
    throw InputError("split_phases", "factor " + std::to_string(factor) +
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

std::vector<MotionFrames> split_phases_keeping_root_path(const MotionFrames& motion, int factor) {
  auto phases = split_phases(motion, factor);
  for (int k = 0; k < factor; ++k) {
    MotionFrames& phase = phases[static_cast<size_t>(k)];
    for (int64_t i = 0; i < phase.frame_count(); ++i) {
      float* root = phase.frame(i);
      for (int a = 0; a < 3; ++a) {
        double change = 0;
        if (i > 0) {
          for (int64_t j = (i - 1) * factor + k + 1; j <= i * factor + k; ++j) change += motion.frame(j)[a];
        }
        root[a] = static_cast<float>(change);
      }
    }
  }
  return phases;
}

}  // namespace mm
