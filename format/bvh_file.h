// BvhFile: a Biovision Hierarchy (BVH) motion file in memory, for any
// skeleton: the hierarchy (names, parents, offsets, channel layout per joint)
// and the frames of channel values, with its parser and writer.
//
// Conventions of the file format, as BVH readers (three.js's BVHLoader,
// Blender) apply them and as bvh_world_positions() below does:
// - column vectors; a joint's local rotation is the product of its rotation
//   channels in the order they are listed (CHANNELS 3 Zrotation Yrotation
//   Xrotation means Rz * Ry * Rx), angles in degrees;
// - world rotation of a joint = world rotation of its parent * local;
//   position = parent position + parent world rotation * (offset + the
//   joint's position channels), i.e. position channels add to the OFFSET;
// - lengths are in the file's unit (cm for the CMU files, mm for ours).
//
// Plain value types; all functions are reentrant (no shared state).
// Errors: malformed text throws InputError "<source>:<line>: ..." naming
// what was found and what was expected. Nothing in a file can crash the
// parser: the hierarchy is parsed without recursion and bounded to
// kMaxBvhJoints nodes, numbers must be finite and within the bounds below,
// and memory grows only with the values actually present (a "Frames:" count
// larger than the lines that follow is an error, not an allocation). What a
// file will cost to resample (its frame count times its frame time) is known
// from its header: it is checked against a limit before any frame is read.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "format/rotation_matrix.h"
#include "format/skeleton.h"

namespace mm {

// Bounds on what a file may hold; beyond them it cannot be a motion.
constexpr int kMaxBvhJoints = 1024;                // joints and end sites together
constexpr double kMaxBvhLength = 1e7;              // offsets and positions, file units
constexpr double kMaxBvhRotationDegrees = 1e6;     // about 2,800 turns
constexpr double kMinBvhFrameTime = 1e-3;          // seconds: 1000 frames a second
constexpr double kMaxBvhFrameTime = 1.0;           // seconds: 1 frame a second

// The rate every imported motion is brought to, that of the model.
constexpr double kBvhImportRate = 25.0;
// The longest take a file may hold: 1,000,000 frames at 25 Hz (11.1 h).
// Checked at the "Frame Time:" line, before any frame is read, so that a
// file of a few kB cannot ask for gigabytes of resampled frames.
constexpr int64_t kMaxBvhImportFrames = 1000000;

// Frames at kBvhImportRate that `frames` file frames of `frame_time_s` make
// (skeleton_motion_from_bvh's count): one at every 1/25 s from the first
// frame's time to the last's, (frames - 1) x frame time; 0 for no frames.
// Callers compare it with their limit before they import.
int64_t bvh_imported_frame_count(int64_t frames, double frame_time_s);

// A bound on the frames at kBvhImportRate a file may make, with the name a
// refusal gives it ("the longest take (11.1 h)", "the model's clip").
struct BvhFrameLimit {
  int64_t frames = kMaxBvhImportFrames;
  std::string name = "the longest take (11.1 h)";
};

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

// "Xposition", ... as the file spells them.
const char* bvh_channel_name(BvhChannel channel);
// The channel a name spells ("Xposition", ...); false for any other text.
bool parse_bvh_channel(const std::string& name, BvhChannel* channel);
// Axis 0..2 of a channel; is_position tells the kind.
int bvh_channel_axis(BvhChannel channel);
bool bvh_channel_is_position(BvhChannel channel);

struct BvhJoint {
  std::string name;          // empty for an End Site (it has no name in the file)
  int parent = -1;           // index into BvhFile::joints, -1 for the root
  Vec3 offset{};             // from the parent, file units
  std::vector<BvhChannel> channels;  // 0..6, no channel twice; none for an End Site
  bool end_site = false;
};

struct BvhFile {
  // Depth-first pre-order as in the file: parents precede children, and
  // each joint's subtree is contiguous. joints[0] is the root.
  std::vector<BvhJoint> joints;
  double frame_time_s = 1.0 / 25.0;
  // Row-major: values[f * channel_count() + c], channels in joint order then
  // each joint's CHANNELS order. Degrees and file units.
  std::vector<double> values;

  int channel_count() const;
  int64_t frame_count() const;  // values.size() / channel_count(), 0 without channels
  // Index of each joint's first channel in a frame's values.
  std::vector<int> first_channels() const;
  // Number of joints that are not End Sites.
  int named_joint_count() const;
};

// The file's frame rate in Hz: 1 / frame time, rounded to a millionth of a
// hertz. Files hold the frame time to a few significant digits (ours to 9:
// 0.00833333333 for 120 Hz, whose inverse is 120.000000048); rounded, a take
// written at 120 Hz reads back at 120 Hz and keeps its frame count when
// resampled to it. A rate within a millionth of a whole number of hertz is
// that number: CMU's 0.00833333 s reads as 120 Hz, not 120.000048.
double bvh_frame_rate(const BvhFile& file);

// Parses BVH text (LF or CRLF line ends, tabs or spaces, a UTF-8 byte-order
// mark at the start). `source_name` names the file in messages. Requires
// exactly one ROOT, unique joint names, 0..6 channels per joint with none
// repeated, at least one channel in all, at least one frame, a frame time in
// [kMinBvhFrameTime, kMaxBvhFrameTime], a declared length that makes at most
// `limit.frames` frames at 25 Hz (bvh_imported_frame_count; checked before
// any frame is read, the refusal naming the limit) and exactly "Frames:"
// lines of exactly channel_count() values. Throws InputError as described
// above.
BvhFile parse_bvh_text(const char* data, size_t size, const std::string& source_name,
                       const BvhFrameLimit& limit = {});
BvhFile parse_bvh_text(const std::string& text, const std::string& source_name, const BvhFrameLimit& limit = {});
// Reads and parses a file; messages name `path`.
BvhFile read_bvh_file(const std::string& path);

// BVH text: tab-indented hierarchy, '\n' line ends, offsets and values with
// 6 decimals, the frame time with 9 significant digits. Throws InputError
// when `file` is not writable as BVH (joints not in depth-first pre-order, an
// End Site with children or channels, a values size that is not a multiple
// of channel_count()).
std::string write_bvh_text(const BvhFile& file);
// Writes atomically (see write_file_atomically).
void write_bvh_file(const BvhFile& file, const std::string& path);

// World positions (file units) of every joint, End Sites included, at
// `frame` (0 <= frame < frame_count(), else std::out_of_range), by the
// conventions above.
std::vector<Vec3> bvh_world_positions(const BvhFile& file, int64_t frame);

// The hierarchy as a Skeleton named `name`, one joint per BVH joint or End
// Site in file order, offsets times `millimetres_per_unit` (10 for a file in
// cm). End Sites are named "<parent>_End" (with "_2", "_3", ... appended
// when that name is taken). Its `bvh` layout records every joint's channels,
// which were End Sites and the unit, so that motions of it are written back
// as BVH of the same rig (skeleton_bvh.h). For training a manifold of one's
// own skeleton.
Skeleton bvh_skeleton(const BvhFile& file, const std::string& name, double millimetres_per_unit = 1.0);

}  // namespace mm
