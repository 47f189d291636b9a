// Motion files as the tool reads and writes them: inputs are H3.6M text at
// 50 Hz from which a window of the model's clip length is taken at 25 Hz;
// outputs are written at 25 Hz. Torch-free.
#pragma once

#include <string>

#include "format/motion_text.h"

namespace mm::tool {

// Reads `path` (50 Hz motion text with `columns` values a frame), keeps every
// second frame (phase 0 of split_phases, 25 Hz) and returns `frames` frames
// starting at 25 Hz frame `start`. Throws InputError naming the file, the
// frames found and the frames needed when the file is too short, and for a
// negative start or a malformed file.
MotionFrames read_motion_window(const std::string& path, int frames, int start, int columns = kH36mColumns);

// Creates `dir` (and its parents) if needed. Throws InputError naming the
// option and the system's reason when it cannot.
void ensure_directory(const std::string& dir, const std::string& option);

// "<dir>/<stem>_<index, 3 digits>.txt".
std::string numbered_motion_path(const std::string& dir, const std::string& stem, int index);

// The help text's note on rates, shared by the commands that read motions.
extern const char* const kMotionRateNote;

}  // namespace mm::tool
