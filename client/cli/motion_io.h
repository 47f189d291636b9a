// Motion files on the client's side, the reader and writer picked by the
// file's extension: ".txt" is exponential-map text of the model's layout
// (format's motion_text: 99 values a line for H3.6M); ".bvh" a BVH of
// the model's skeleton, H3.6M's or a rig learnt from BVH files
// (format's skeleton_bvh, as the server's REST frontend converts it);
// "-" is text on standard input or output. The model's layout and skeleton
// come from the server (model_rig.h). Inputs are brought to the models'
// 25 Hz and cut to one clip, as the motion-manifold tool does
// (model/tool/motion_files.h). Torch-free.
#pragma once

#include <string>
#include <vector>

#include "client/cli/model_rig.h"
#include "format/motion_frames.h"
#include "motionmanifold/v1/manifold.pb.h"

namespace mm::client {

namespace v1 = motionmanifold::v1;

constexpr int kModelRate = 25;  // Hz of the models' clips and of every motion written

// Which motion input the user gave: a file, its rate (25 or 50 Hz) and the
// clip's first frame in the file's own frames (a text file's row, a BVH's
// frame).
struct MotionSource {
  std::string path;
  int rate = 50;
  int start = 0;
};

// Reads `source` as a motion of `model` ("" the active one; its rig asked of
// `rigs` once the file has been read and, for BVH, parsed), brings it to
// 25 Hz (every second row of text at 50 Hz from row `start`; a BVH resampled
// from its frame `start`) and returns the model's clip length of frames as a
// Motion message (25 Hz, the model's
// layout). Throws InputError naming the file when it cannot be read, is
// malformed or too short (a BVH of another skeleton names what differs);
// ServerError when the model cannot be described.
v1::Motion read_motion(const MotionSource& source, ModelRigs& rigs, const std::string& model);

// The same with every frame from `start` to the file's end instead of one
// clip (join's clips, of any length), at 25 Hz.
v1::Motion read_whole_motion(const MotionSource& source, ModelRigs& rigs, const std::string& model);

// Reads a code file: JSON {"code": [...]} as `encode` prints it, a reply of
// encode --json ({"codes": [[...]]}, its first code) or a bare array.
// Throws InputError naming the file.
v1::Code read_code(const std::string& path);

// Whether `path` names a code (".json") rather than a motion.
bool is_code_file(const std::string& path);

// Whether `path` names a motion file (".txt" or ".bvh", in any case).
bool is_motion_file(const std::string& path);

// Writes a motion (as the server returns it) of `model` to `path`, the
// writer picked by extension as above (BVH in the layout of the model's rig,
// asked of `rigs`). Throws InputError for an unwritable path.
void write_motion(const v1::Motion& motion, const std::string& path, ModelRigs& rigs, const std::string& model);

// Writes the motions of `model` to "<dir>/<stem>_000.<extension>", "_001",
// ... (the tool's numbering), creating `dir`, each as write_motion() does
// ("txt" or "bvh"); returns the paths written.
std::vector<std::string> write_numbered_motions(const google::protobuf::RepeatedPtrField<v1::Motion>& motions,
                                                const std::string& dir, const std::string& stem,
                                                const std::string& extension, ModelRigs& rigs,
                                                const std::string& model);

// Checks before any call that `path` can be written by a built-in writer,
// so a mistyped extension fails before the server does the work.
void check_motion_output(const std::string& path, const std::string& option);

// The help text's note on input motions, shared by the commands.
extern const char* const kMotionInputNote;

}  // namespace mm::client
