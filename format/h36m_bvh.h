// Conversion between motions in the H3.6M text layout (MotionFrames of 99
// columns, see motion_text.h) and BVH files of the 32-joint H3.6M skeleton
// (Skeleton::h36m()).
//
// Poses: a BVH reader's forward kinematics of the exported file gives the
// joint positions of ours (model/forward_kinematics.h, the skeleton file's
// row-vector convention) to rounding: the H3.6M local rotation R (applied to
// row vectors) is the column-vector rotation R^T, which is written as Euler
// angles in degrees, converted exactly. The root rotation columns (3..5) are
// the root's orientation, as in our FK.
//
// Root position: the text layout's columns 0..2 are per-frame changes of the
// root translation in mm (frame 0 holds zeros in the data set). BVH wants
// positions, so the export writes their running sum (frame f: the sum of
// frames 0..f) and the import writes differences of consecutive positions
// at 25 Hz (frame 0: the root's position, so that a reply exported again
// starts where the file did). The model ignores these columns.
//
// The 7 leaves of H3.6M (RightToeBase_End, ..., RightWrist_End_Site) carry no
// motion (rotating a leaf moves no joint) and are written as End Sites, so a
// reader sees the usual 25 joints with channels and 7 end sites; they read
// back as zero rotations.
//
// These are skeleton_bvh.h's conversions for Skeleton::h36m() with its
// default BVH layout. All functions are reentrant. Bad input throws
// InputError naming the source.
#pragma once

#include <string>

#include "format/bvh_file.h"
#include "format/motion_text.h"
#include "format/rotation_matrix.h"
#include "format/skeleton_bvh.h"

namespace mm {

// The rate every imported motion is brought to, that of the model.
constexpr double kH36mBvhImportRate = kBvhImportRate;
// Imports that would be longer than this at 25 Hz are refused (about 11 h),
// bounding memory for a file with a long frame time.
constexpr int64_t kMaxH36mBvhImportFrames = kMaxBvhImportFrames;

struct H36mBvhExportOptions {
  // The rotation channel order of every joint (default Zrotation Yrotation
  // Xrotation).
  EulerOrder rotation_order;
  // Also give every joint other than the root Xposition Yposition Zposition
  // channels (zero, since they add to the offset), for readers that want 6
  // channels everywhere.
  bool position_channels_on_every_joint = false;
};

// The motion (99 columns, >= 1 frame, finite values) at `rate_hz` (frame
// time 1 / rate_hz: 25 or 50 for ours; any rate of 1 to 1000 Hz) as a BVH
// of the H3.6M skeleton with offsets in mm: root with Xposition Yposition
// Zposition and the rotation channels, the other 24 joints with rotation
// channels. Throws InputError for another column count, no frames, a bad
// rate or a non-finite value.
BvhFile h36m_motion_to_bvh(const MotionFrames& motion, double rate_hz, const H36mBvhExportOptions& options = {});

// The text of h36m_motion_to_bvh.
std::string h36m_motion_to_bvh_text(const MotionFrames& motion, double rate_hz,
                                    const H36mBvhExportOptions& options = {});

// A BVH of the H3.6M skeleton back as 99-column frames at 25 Hz. Accepted:
// any rotation channel order per joint, position channels on any joint
// (those of joints other than the root are ignored: the bone lengths are
// the skeleton's), leaves as End Sites or as joints, offsets that differ
// from ours (a person of another size: only rotations are taken), any frame
// time. Root positions are taken as mm.
//
// Resampling: output frame k is the file's frame nearest in time to k/25 s
// (ties to the later frame), over the file's duration (frames - 1) * frame
// time: nearest, not interpolated, so a 50 Hz file gives exactly its even
// frames and a 25 Hz file all of its frames.
//
// Throws InputError "<source_name>: not the H3.6M skeleton (h36m-32): ..."
// naming what differs (joint and end site counts, missing and unexpected
// joints, a joint with another parent) for another hierarchy; and when the
// result would exceed kMaxH36mBvhImportFrames or a root position change
// would exceed kMaxRootTranslationMm.
MotionFrames h36m_motion_from_bvh(const BvhFile& file, const std::string& source_name);

// Parses BVH text and converts it as above.
MotionFrames h36m_motion_from_bvh_text(const std::string& text, const std::string& source_name);

}  // namespace mm
