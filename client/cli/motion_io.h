// Motion files on the client's side, the reader and writer picked by the
// file's extension: ".txt" is H3.6M exponential-map text (model/format's
// motion_text); ".bvh" a BVH of the H3.6M skeleton (model/format's
// h36m_bvh); "-" is text on standard input or output.
// Inputs are brought to the models' 25 Hz and cut to one clip, as the
// motion-manifold tool does (model/tool/motion_files.h). Torch-free.
#pragma once

#include <string>
#include <vector>

#include "format/motion_text.h"
#include "motionmanifold/v1/manifold.pb.h"

namespace mm::client {

namespace v1 = motionmanifold::v1;

constexpr int kModelRate = 25;        // Hz of the models' clips and of every motion written
constexpr int kClipFrames = 150;      // frames of one clip at 25 Hz (6 s), the shipped models'
constexpr const char* kLayout = "h36m-expmap-99";

// Which motion input the user gave: a file, its rate (25 or 50 Hz) and the
// first 25 Hz frame of the clip.
struct MotionSource {
  std::string path;
  int rate = 50;
  int start = 0;
};

// Reads `source`, brings it to 25 Hz (every second frame at 50 Hz) and
// returns its `frames` frames from `start` as a Motion message (25 Hz,
// h36m-expmap-99). Throws InputError naming the file when it cannot be read,
// is malformed or too short (a BVH of another skeleton names what differs).
v1::Motion read_motion(const MotionSource& source, int frames = kClipFrames);

// Reads a code file: JSON {"code": [...]} as `encode` prints it, a reply of
// encode --json ({"codes": [[...]]}, its first code) or a bare array.
// Throws InputError naming the file.
v1::Code read_code(const std::string& path);

// Whether `path` names a code (".json") rather than a motion.
bool is_code_file(const std::string& path);

// Writes a motion (as the server returns it) to `path`, the writer picked
// by extension as above. Throws InputError for an unwritable path.
void write_motion(const v1::Motion& motion, const std::string& path);

// Writes the motions to "<dir>/<stem>_000.txt", "_001", ... (the tool's
// numbering), creating `dir`; returns the paths written.
std::vector<std::string> write_numbered_motions(const google::protobuf::RepeatedPtrField<v1::Motion>& motions,
                                                const std::string& dir, const std::string& stem);

// Checks before any call that `path` can be written by a built-in writer,
// so a mistyped extension fails before the server does the work.
void check_motion_output(const std::string& path, const std::string& option);

// The help text's note on input motions, shared by the commands.
extern const char* const kMotionInputNote;

}  // namespace mm::client
