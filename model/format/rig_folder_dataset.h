// A prepared dataset from a folder of BVH files of one hierarchy: a user's
// own skeleton, for training a manifold of it (Sec. 4's preparation, with the
// skeleton, the kept dimensions and the statistics derived from the files).
//
// The skeleton (names, parents, offsets, channel layout and unit) is that of
// the first file in path order (bvh_skeleton()); every other file must have
// the same hierarchy (skeleton_bvh.h's matching: any channel order, other
// offsets are fine, the bone lengths are the first file's). Every file
// becomes one sequence in the skeleton's exp-map layout at 25 Hz (nearest
// frames, skeleton_bvh.h), in the "train" or the "test" split by file:
// PreparedSequence::subject is "train" or "test", action the file's path
// relative to the folder without ".bvh", take and phase 0. The
// normalisation is fitted on the training files only.
//
// Thread safe (no shared state). Errors are InputError naming the file (and
// line, for malformed BVH), the option or the value.
#pragma once

#include <string>
#include <vector>

#include "format/bvh_file.h"
#include "format/prepared_dataset.h"

namespace mm {

struct BvhFolderOptions {
  // The skeleton's name, carried into models trained on it; empty: the
  // folder's name.
  std::string skeleton_name;
  // The files' length unit in mm (10 for cm); 0: detected from the height
  // of the first file's rest pose (see detect_bvh_millimetres_per_unit).
  double millimetres_per_unit = 0;
  // The test files: paths relative to the folder, of files ("martial/03.bvh")
  // or folders ("martial", every file under it). Empty: every fifth file in
  // path order (the 5th, 10th, ...), or the last one of 2 to 4 files.
  std::vector<std::string> test_files;
  double min_std = 1e-4;  // columns with a smaller training std are dropped
};

// The .bvh files (any case) under `folder`, recursively, as paths relative
// to it with '/' separators, sorted. Throws InputError naming the folder when
// it is not a readable folder or holds no .bvh file.
std::vector<std::string> list_bvh_files(const std::string& folder);

// Millimetres per unit of a file whose rest pose (every channel 0) spans
// `extent` units along its longest axis, taking it for a person 0.5 to 3 m
// tall: 1 (mm) for 500..3000, 10 (cm) for 50..300, 1000 (m) for 0.5..3.
// Throws InputError naming `source_name`, the extent and the --unit option
// for anything else (inches, or not a person: give the unit).
double detect_bvh_millimetres_per_unit(const BvhFile& file, const std::string& source_name);

// Reads, converts, splits and normalises the folder as described above.
// Throws InputError for a folder without BVH files, a malformed file, a
// file of another hierarchy (naming it and what differs), a test entry that
// names no file, a split that leaves no training or no test file, or a unit
// that cannot be detected.
PreparedDataset prepare_bvh_folder(const std::string& folder, const BvhFolderOptions& options);

// The training files of a dataset prepare_bvh_folder made, read again from
// its bvh_folder in the skeleton's world layout at 25 Hz with their root
// (skeleton_motion_from_bvh): what a rig's root trajectory network learns
// from. Throws InputError for a dataset of no BVH folder, or naming a
// training file no longer there.
std::vector<MotionFrames> read_bvh_training_motions(const PreparedDataset& data);

}  // namespace mm
