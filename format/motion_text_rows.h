// Rows of motion text (motion_text.h) for a reader that needs only a window
// of a file (a clip of the model's length from some row): the rows counted
// against a limit without parsing a value, then only the window's parsed,
// so that a long file costs a scan, not its parse.
//
// Reentrant, as motion_text.h. Implemented in motion_text.cpp beside the
// parser whose rules it shares.
#pragma once

#include <cstdint>
#include <string>

#include "format/motion_text.h"

namespace mm {

// The most rows a motion text may hold where only a window of it is read
// (ReadClip): 2,000,000, 11.1 h at 50 Hz, the longest take a BVH may hold
// too (bvh_file.h).
constexpr int64_t kMaxMotionTextRows = 2000000;

// The rows (non-blank lines) of motion text, counted and each checked to
// hold `expected_columns` values, without parsing a value. Throws
// InputError "<source>:<line>: ..." for a row of another value count, a
// blank line followed by more rows (as parse_motion_text does), no rows at
// all, or more than `max_rows` rows (naming the limit, at the first row past
// it).
int64_t count_motion_text_rows(const char* data, size_t size, const std::string& source_name,
                               int expected_columns = kH36mColumns, int64_t max_rows = kMaxMotionTextRows);

// Rows first_row .. first_row + row_count - 1 of motion text, parsed and
// checked as parse_motion_text_buffer does; the rows before them are only
// counted, the rows after them not read. Throws InputError as
// parse_motion_text_buffer (NaN taken in the joint columns when
// `nan_is_missing`), and when the text has fewer rows.
MotionFrames parse_motion_text_rows(const char* data, size_t size, const std::string& source_name,
                                    int expected_columns, int64_t first_row, int64_t row_count,
                                    bool nan_is_missing = false);

}  // namespace mm
