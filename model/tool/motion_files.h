// Motion files as the tool reads and writes them: inputs are exp-map text
// (H3.6M's layout or that of the model's skeleton) at 50 Hz (the data set) or
// 25 Hz (what the tool writes), or BVH files of the model's skeleton at any
// frame rate (format/skeleton_bvh.h), from which a window of the model's clip
// length is taken at 25 Hz; outputs are written at 25 Hz, as BVH of the
// skeleton's own layout when the path ends in ".bvh", else as text. Torch-free.
// glTF (.glb, .gltf) and FBX (.fbx) go wherever BVH does, in and out (FBX in
// only), through format/animation_file.h, in the rig's BVH layout and unit.
#pragma once

#include <string>

#include "format/bvh_file.h"
#include "format/motion_text.h"
#include "format/skeleton.h"

namespace mm::tool {

// The model's frame rate, of every motion the tool writes.
constexpr int kModelRate = 25;
// The rate of the data set's files, the default of the commands that encode.
constexpr int kDataSetRate = 50;

// `motion` at the model's 25 Hz: as it is for rate 25, every second frame
// (phase 0 of split_phases, as prepare downsamples) for rate 50. Throws
// InputError naming `name` for any other rate.
MotionFrames at_model_rate(const MotionFrames& motion, int rate, const std::string& name);

// Whether `path` names a BVH file: it ends in ".bvh" (any case).
bool is_bvh_path(const std::string& path);

// Whether an input is BVH: its path ends in ".bvh", or (for standard input
// and other names) its first word is HIERARCHY, which no motion text holds.
bool is_bvh_input(const std::string& path, const std::string& text);

// Whether `path` names an animation file: it ends in ".bvh", ".glb",
// ".gltf" or ".fbx" (any case).
bool is_animation_path(const std::string& path);

// Whether an input is an animation file: its path says so, or (for standard
// input and other names) its first bytes are BVH's HIERARCHY, glTF's or
// FBX's, which no motion text holds.
bool is_animation_input(const std::string& path, const std::string& text);

// An animation input as a BVH of the skeleton's rig (glTF and FBX in the unit
// of the skeleton's BVH layout). Throws InputError naming `name`.
BvhFile parse_animation_input(const std::string& text, const std::string& name, const Skeleton& skeleton);

// The bytes of `file`, a BVH of the skeleton's rig, in the format `path`'s
// extension names. Throws InputError for FBX, which is not written.
std::string animation_output_bytes(const BvhFile& file, const std::string& path, const Skeleton& skeleton);

// The whole motion of an input at 25 Hz: BVH is converted and resampled to
// 25 Hz (its frame time decides; `rate` is ignored), text at `rate` as
// at_model_rate. Throws InputError naming `name`.
// Motions are of `skeleton` (the model's): 3 + 3 x its joints columns.
MotionFrames motion_at_model_rate(const std::string& text, const std::string& name, int rate,
                                  const Skeleton& skeleton = Skeleton::h36m());

// Parses `text` (motion text at `rate` Hz, 25 or 50, with `columns` values a
// frame, or BVH as is_bvh_input(name, text) tells; `name` is the file's name
// in messages) and returns `frames` frames at 25 Hz from the file's own frame
// `start`: a text file's row (at 50 Hz every second row from it is kept), a
// BVH's frame (resampled to 25 Hz from there), the unit of the service's
// ReadClip start and of a take's start_frame. Throws InputError naming the
// file, the frames found and the frames needed when it is too short, and
// for a negative start or a malformed file.
MotionFrames motion_window(const std::string& text, const std::string& name, int frames, int start, int rate,
                           const Skeleton& skeleton = Skeleton::h36m());

// Writes a motion (at 25 Hz) to `path`: BVH for a path ending in ".bvh"
// (frame time 0.04 s) of `skeleton` in its BVH layout, else text; standard
// output ("-") gets text.
void write_motion_output(const MotionFrames& motion, const std::string& path,
                         const Skeleton& skeleton = Skeleton::h36m());

// Creates `dir` (and its parents) if needed. Throws InputError naming the
// option and the system's reason when it cannot.
void ensure_directory(const std::string& dir, const std::string& option);

// "<dir>/<stem>_<index, 3 digits>.<extension>".
std::string numbered_motion_path(const std::string& dir, const std::string& stem, int index,
                                 const std::string& extension = "txt");

// The help text's note on rates, shared by the commands that read motions.
extern const char* const kMotionRateNote;

}  // namespace mm::tool
