// H36mCorpus: loading the Human3.6M exponential-map text files of a set of
// subjects into memory as downsampled sequences.
#pragma once

#include <string>
#include <vector>

#include "format/motion_text.h"

namespace mm {

// One downsampled phase of one recorded file.
struct MotionSequence {
  std::string subject;  // "S1", ...
  std::string action;   // "walking", ...
  int take = 0;         // 1 or 2 (the _1/_2 file suffix)
  int phase = 0;        // 0..downsample-1: first 50 Hz frame kept (split_phases)
  MotionFrames frames;  // 99 columns, at 50 / downsample Hz
};

// The 15 H3.6M action names, in the order of Martinez et al.
const std::vector<std::string>& h36m_actions();

// Resolves the folder that holds S1, S5, ...: `dir` itself when it has S*
// sub-folders, else <dir>/h3.6m/dataset, else <dir>/dataset. Throws
// InputError naming `dir` when none of these exists.
std::string resolve_h36m_dataset_dir(const std::string& dir);

// Reads <dir>/S*/<action>_<take>.txt (the 15 actions, takes 1 and 2) for the
// listed subjects; `dir` is resolved as in resolve_h36m_dataset_dir. Files
// absent from the copy are skipped. Each file is downsampled by `downsample`
// (50 Hz -> 25 Hz for 2), keeping every phase as its own sequence
// (split_phases). Result sorted by subject (numerically: S1, S5, ..., S11),
// action, take, phase. Files are parsed in parallel on up to 4 std::threads.
// Throws InputError when a listed subject folder does not exist, a subject
// name is not a plain folder name, downsample < 1, or a file is malformed
// (the message names the file and line). Thread safe (no shared state).
std::vector<MotionSequence> load_h36m_corpus(const std::string& dir,
                                             const std::vector<std::string>& subjects,
                                             int downsample = 2);

}  // namespace mm
