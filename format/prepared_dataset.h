// PreparedDataset: H3.6M downsampled, normalised and split into train and
// test subjects, stored in one compact file so that training and evaluation
// start in seconds instead of re-parsing ~440 MB of text.
//
// File format (all integers little-endian), version 1:
//   offset 0   8 bytes   magic "MMPREP\r\n" (the \r\n catches text-mode mangling)
//          8   uint32    version (1)
//         12   uint64    H = header length in bytes
//         20   H bytes   header, UTF-8 JSON:
//                          {"normalization": <PoseNormalization JSON object>,
//                           "train_subjects": [...], "test_subjects": [...],
//                           "frame_rate": 25, "dims": D, "levels_per_std": 8192,
//                           "skeleton": <Skeleton JSON object> (absent in
//                             files of H3.6M written before it: H3.6M's),
//                           "bvh_folder": "..." (only for a rig folder's;
//                             the name from when it held BVH only),
//                           "sequences": [{"subject", "action", "take", "phase",
//                                          "frames"}, ...]}
//     20 + H   uint64    R = payload length before compression (bytes)
//     28 + H   uint64    C = compressed payload length (bytes)
//     36 + H   uint32    CRC-32 (zlib) of the compressed payload
//     40 + H   C bytes   zlib stream of the payload; the file ends here.
// Payload: for each sequence in header order, for each dimension d, its
// frames' standardised values quantised to int32 levels q = round(x * 8192)
// (a fixed grid: error <= 2^-14 = 6.1e-5 std whatever the value's range),
// stored as differences from the previous frame's level (the first frame
// from 0), zigzag-coded to uint32 (0,-1,1,-2 -> 0,1,2,3). The N codes are
// split into 4 byte planes, plane p (least significant first) at p*N..,
// because the upper planes of small differences are nearly all zero and
// compress to almost nothing. Full H3.6M (S1,S5,S6,S7,S8,S9,S11, 378
// sequences at 25 Hz, 51 dims): 30.8 MB, loads in ~0.3 s (measured 2 cores).
#pragma once

#include <string>
#include <vector>

#include "format/motion_frames.h"
#include "format/pose_normalization.h"
#include "format/skeleton.h"

namespace mm {

struct PreparedSequence {
  std::string subject, action;
  int take = 0, phase = 0;
  MotionFrames normalized;  // columns = normalization.dims(), standardised units, at frame_rate Hz
};

// Plain value type; const methods may be called concurrently.
struct PreparedDataset {
  PoseNormalization normalization;  // fitted on train subjects only
  std::vector<std::string> train_subjects, test_subjects;
  int frame_rate = 25;              // Hz of every sequence
  // The skeleton the frames are motions of (its exp-map layout, skeleton_bvh.h):
  // H3.6M's, or a user's own from prepare_rig_folder (rig_folder_dataset.h).
  Skeleton skeleton = Skeleton::h36m();
  // The folder prepare_rig_folder read, absolute (header "bvh_folder", so
  // that files written when it held BVH only still read), whose files hold
  // the root's path the normalised frames drop: a rig's root trajectory
  // network is trained from them. Empty for H3.6M.
  std::string rig_folder;
  std::vector<PreparedSequence> sequences;  // train and test subjects, sorted as load_h36m_corpus

  // The sequences of the listed subjects, in stored order. Pointers are valid
  // while `sequences` is not modified. Unknown subjects give no sequences.
  std::vector<const PreparedSequence*> subset(const std::vector<std::string>& subjects) const;
};

struct SplitOptions {
  std::vector<std::string> train_subjects{"S1", "S6", "S7", "S8", "S9", "S11"};
  std::vector<std::string> test_subjects{"S5"};
  int downsample = 2;    // 50 Hz / downsample; must divide 50
  double min_std = 1e-4; // columns with a smaller training std are dropped
};

// Loads the listed subjects (see load_h36m_corpus for `dataset_dir`), fits
// the normalization on the train subjects' frames and normalises every
// sequence. Throws InputError for a missing subject folder, malformed files,
// a subject listed as both train and test, an empty train list, or a
// downsample that does not divide 50. Thread safe.
PreparedDataset prepare_h36m(const std::string& dataset_dir, const SplitOptions& options);

// Writes the file format above atomically (temporary file + rename).
// Throws InputError if the dataset is inconsistent (a sequence's columns differ
// from normalization.dims(), a non-finite value) or the directory is not
// writable, std::runtime_error on I/O failure.
void save_prepared_dataset(const PreparedDataset& data, const std::string& path);

// Reads a file written by save_prepared_dataset. Values come back within the
// quantisation error documented above. Throws InputError naming `path` for a
// missing or unreadable file, wrong magic or version, a truncated or corrupt
// file (CRC, sizes, JSON) or trailing bytes. Thread safe.
PreparedDataset load_prepared_dataset(const std::string& path);

}  // namespace mm
