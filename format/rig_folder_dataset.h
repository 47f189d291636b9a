// A prepared dataset from a folder of animation files of one hierarchy: a
// user's own rig, for training a manifold of it (Sec. 4's preparation, with
// the skeleton, the kept dimensions and the statistics derived from the
// files). The files are BVH, glTF 2.0 (.glb, .gltf) and FBX (.fbx), any
// case, mixed, each read by the animation-file reader (animation_file.h) at
// its own rate.
//
// The skeleton (names, parents, offsets, channel layout and unit) is that of
// the first file in path order (bvh_skeleton() of it as read); every other
// file must have the same hierarchy (skeleton_bvh.h's matching: any channel
// order, other offsets are fine, the bone lengths are the first file's; End
// Sites, which animation tools drop, may be present or not). Every file
// becomes one sequence in the skeleton's exp-map layout at 25 Hz (nearest
// frames, skeleton_bvh.h), in the "train" or the "test" split by file:
// PreparedSequence::subject is "train" or "test", action the file's path
// relative to the folder without its extension ("martial/03"; two files of
// one such name are refused), take and phase 0. The normalisation is fitted
// on the training files only.
//
// Units: a BVH is in its own unit, one for every BVH file of the folder
// (given, or told from the first BVH file's rest pose); glTF is in metres
// and FBX in its file's unit (UnitScaleFactor; cm without one), which the
// reader converts to the skeleton's BVH unit. The skeleton's
// BVH unit (what a model trained on it writes BVH in) is the BVH files'
// unit; for a folder of glTF and FBX files only, the given unit, else mm.
// Either way the prepared values (root moves, offsets) are mm, the same
// for a motion as BVH or as glTF or FBX.
//
// Thread safe (no shared state). Errors are InputError naming the file (and
// line, for malformed BVH), the option or the value.
#pragma once

#include <string>
#include <vector>

#include "format/bvh_file.h"
#include "format/prepared_dataset.h"
#include "format/skeleton.h"

namespace mm {

struct RigFolderOptions {
  // The skeleton's name, carried into models trained on it; empty: the
  // folder's name.
  std::string skeleton_name;
  // The BVH files' length unit in mm (10 for cm), and the skeleton's; 0:
  // detected from the height of the first BVH file's rest pose (see
  // detect_bvh_millimetres_per_unit), or mm for a folder without BVH files.
  double millimetres_per_unit = 0;
  // The test files: paths relative to the folder, of files ("martial/03.bvh")
  // or folders ("martial", every file under it). Empty: every fifth file in
  // path order (the 5th, 10th, ...), or the last one of 2 to 4 files.
  std::vector<std::string> test_files;
  double min_std = 1e-4;  // columns with a smaller training std are dropped
};

// The animation files (.bvh, .glb, .gltf, .fbx, any case) under `folder`,
// recursively, as paths relative to it with '/' separators, sorted. Throws
// InputError naming the folder when it is not a readable folder or holds no
// animation file.
std::vector<std::string> list_animation_files(const std::string& folder);

// Throws InputError naming both files when two of `files` (as
// list_animation_files gives them) have one name without their extensions
// ("03.bvh" and "03.glb"): a sequence is named so.
void check_one_file_per_name(const std::vector<std::string>& files, const std::string& folder);

// Millimetres per unit of a file whose rest pose (every channel 0) spans
// `extent` units along its longest axis, taking it for a person 0.5 to 3 m
// tall: 1 (mm) for 500..3000, 10 (cm) for 50..300, 1000 (m) for 0.5..3.
// Throws InputError naming `source_name`, the extent and the --unit option
// for anything else (inches, or not a person: give the unit).
double detect_bvh_millimetres_per_unit(const BvhFile& file, const std::string& source_name);

// The animation file at `path` (its format by its extension) as a BVH of
// the rig's unit `millimetres_per_unit` (a BVH as it is, in its own).
// Throws InputError naming the path for a malformed or unreadable file.
BvhFile read_rig_file(const std::string& path, double millimetres_per_unit);

// The animation file at `path`, a motion of `skeleton`'s hierarchy, at
// 25 Hz in the skeleton's exp-map layout with its root
// (skeleton_motion_from_bvh; glTF and FBX in the unit of the skeleton's BVH
// layout). Throws InputError naming the path, as skeleton_motion_from_bvh
// and read_rig_file do.
MotionFrames read_rig_motion(const Skeleton& skeleton, const std::string& path);

// Reads, converts, splits and normalises the folder as described above.
// Throws InputError for a folder without animation files, two files of one
// name, a malformed file, a file of another hierarchy (naming it and what
// differs), a test entry that names no file, a split that leaves no
// training or no test file, or a unit that cannot be detected.
PreparedDataset prepare_rig_folder(const std::string& folder, const RigFolderOptions& options);

// The training files of a dataset prepare_rig_folder made, read again from
// its rig_folder by read_rig_motion: what a rig's root trajectory network
// learns from. Throws InputError for a dataset of no rig folder, or naming a
// training file no longer there.
std::vector<MotionFrames> read_rig_training_motions(const PreparedDataset& data);

}  // namespace mm
