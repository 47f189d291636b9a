// Motion text: the exponential-map text layout of Human3.6M used by Martinez
// et al. 2017 (one frame a line, comma-separated floats with 7 decimals, no
// header, 50 Hz), read into and written from MotionFrames
// (format/motion_frames.h).
//
// All functions here are reentrant: they touch only their arguments, so they
// may be called concurrently on different objects.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "format/motion_frames.h"

namespace mm {

// The largest magnitudes the parser accepts. Values beyond them cannot come
// from a motion and would overflow float arithmetic downstream (forward
// kinematics squares them), so they are refused as bad input. The bounds are
// generous: in H3.6M the root moves at most about 55 mm a frame and every
// exponential-map value is within pi.
constexpr double kMaxRootTranslationMm = 1e5;            // 100 m a frame
constexpr double kMaxRotationRadians = 1e3;              // about 160 turns

// Parses motion text from `in`. `source_name` is used only in error messages
// (give the file name). Every non-blank line must hold exactly
// `expected_columns` finite numbers separated by commas, the first
// kRootTranslationValues within +-kMaxRootTranslationMm and the rest within
// +-kMaxRotationRadians; spaces around a value, a trailing '\r', blank lines
// at the end and a UTF-8 byte-order mark at the start (some editors write
// one) are accepted.
// Returns frames with columns == expected_columns and at least one frame.
// Throws InputError "<source>:<line>: ..." naming the offending value (and
// its column) and what was expected: wrong number of values, a value that is
// not a number, NaN or infinity, a value out of the bounds above, a blank
// line followed by more frames, or no frames at all.
MotionFrames parse_motion_text(std::istream& in, const std::string& source_name,
                               int expected_columns = kH36mColumns);

// Same as parse_motion_text on an in-memory buffer (used by the file reader,
// which reads the whole file at once for speed).
MotionFrames parse_motion_text_buffer(const char* data, size_t size,
                                      const std::string& source_name,
                                      int expected_columns = kH36mColumns);

// The same, taking NaN ("nan", "NaN") in the joint columns when
// `nan_is_missing`: a value missing from a take (a marker that dropped out),
// for denoising to fill. NaN in the root translation is still refused.
MotionFrames parse_motion_text_buffer(const char* data, size_t size, const std::string& source_name,
                                      int expected_columns, bool nan_is_missing);

// Reads and parses the file at `path`; error messages name `path`.
// Throws InputError when the file cannot be opened or is malformed.
MotionFrames read_motion_text(const std::string& path, int expected_columns = kH36mColumns);

// Writes one line per frame, values with 7 decimals ("%.7f", as in the data
// set) separated by commas, '\n' line ends. Throws std::runtime_error if the
// stream fails. Float values round-trip to within 5e-8 absolute plus one
// float ulp.
void write_motion_text(const MotionFrames& motion, std::ostream& out);

// Writes the file atomically (temporary file in the same directory, then
// rename), so readers never see a partial file. Throws InputError when the
// directory is not writable, std::runtime_error on I/O failure.
void write_motion_text_file(const MotionFrames& motion, const std::string& path);

// Splits a sequence into `factor` sequences at rate/factor: phase k holds
// frames k, k+factor, k+2*factor, ... (Martinez et al. keep only phase 0 when
// downsampling 50 -> 25 Hz; keeping every phase uses all recorded frames).
// Returns exactly `factor` sequences with motion's column count; a phase is
// empty when motion has fewer than k+1 frames. factor 1 returns a copy.
// Throws InputError when factor < 1.
std::vector<MotionFrames> split_phases(const MotionFrames& motion, int factor);

// The same phases with the root's change over each kept frame's span: frame
// k of phase p holds the sum of columns 0..2 of input frames (k - 1) x
// factor + p + 1 .. k x factor + p (0 in frame 0), so the running sum of
// the phase is the input's root path at the kept frames. split_phases keeps
// the input's per-frame change, which is the root's motion over one input
// frame only (half of it for H3.6M's 50 Hz at 25 Hz). Throws as split_phases.
std::vector<MotionFrames> split_phases_keeping_root_path(const MotionFrames& motion, int factor);

}  // namespace mm
