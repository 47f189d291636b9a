// Conversion between motions in the exponential-map layout of a skeleton and
// BVH files of that skeleton's hierarchy, for any skeleton: H3.6M's
// (h36m_bvh.h is this with Skeleton::h36m()) or a user's own rig derived from
// its BVH files by bvh_skeleton().
//
// The layout generalises H3.6M's text layout (motion_text.h), so that
// normalisation, forward kinematics and training take it unchanged:
// 3 + 3 x joint_count() columns a frame; columns 0..2 the change of the root
// position since the previous frame in mm (0 in frame 0), then every joint of
// the skeleton (End Sites included: they carry no motion and read as zeros)
// as 3 exponential-map values in radians, joint j at 3+3j..5+3j. A joint's
// exponential map is its local rotation R for row vectors (the convention of
// model/forward_kinematics.h), the transpose of the BVH's column-vector
// local matrix, so a BVH reader's forward kinematics of an exported file
// gives the positions of ours to rounding.
//
// Root position: BVH holds positions, the layout changes; the export writes
// the running sum of the changes (frame f: the sum of frames 0..f), the
// import the differences of consecutive positions at 25 Hz, frame 0's the
// root's position itself, so that an exported reply starts where the file
// did. Lengths are
// converted by the layout's millimetres_per_unit (10 for a file in cm).
//
// All functions are reentrant. Bad input throws InputError naming the source.
#pragma once

#include <string>
#include <vector>

#include "format/bvh_file.h"
#include "format/motion_text.h"
#include "format/rotation_matrix.h"
#include "format/skeleton.h"

namespace mm {

// Columns of a motion of `skeleton`: 3 + 3 x joint_count() (99 for H3.6M).
int skeleton_motion_columns(const Skeleton& skeleton);

// The Euler order whose first axes are a joint's rotation channels in their
// order, completed by the axes it lacks; `rotation_count`, where given,
// receives how many rotation channels the joint has.
EulerOrder bvh_rotation_order(const std::vector<BvhChannel>& channels, int* rotation_count = nullptr);

// A BVH layout for a skeleton that came from no BVH file: leaves as End
// Sites, the root with Xposition Yposition Zposition then the rotation
// channels in `rotation_order`, every other joint the rotation channels only
// (also zero position channels when `position_channels_on_every_joint`, for
// readers that want 6 channels everywhere), lengths in mm.
BvhLayout default_bvh_layout(const Skeleton& skeleton, const EulerOrder& rotation_order = {},
                             bool position_channels_on_every_joint = false);

// The skeleton's own layout (skeleton.bvh) when it has one, else the default.
BvhLayout bvh_layout_of(const Skeleton& skeleton);

// The motion (skeleton_motion_columns() columns, >= 1 frame, finite values)
// at `rate_hz` (frame time 1 / rate_hz; any rate of 1 to 1000 Hz, what BVH files may hold) as a BVH
// of the skeleton in `layout`: joint names, End Sites, channels and unit as
// the layout says, offsets the skeleton's. A joint with fewer than 3 rotation
// channels gets the angles of its rotation about those axes (its Euler
// decomposition in their order, completed by the missing axes), so only
// rotations about them survive. Throws InputError for another column count,
// a layout of another joint count, no frames, a bad rate or a non-finite value.
BvhFile skeleton_motion_to_bvh(const Skeleton& skeleton, const BvhLayout& layout, const MotionFrames& motion,
                               double rate_hz);

// A BVH of the skeleton's hierarchy back as motion frames of the skeleton at
// 25 Hz. Joints are matched by name (an End Site is named as bvh_skeleton()
// names it; a leaf of the skeleton may be an End Site in the file, or a joint
// with or without channels). Accepted: any rotation channel order per joint,
// position channels on any joint (those of joints other than the root are
// ignored: the bone lengths are the skeleton's), offsets that differ from
// the skeleton's (a person of another size: only rotations are taken), any
// frame time. Root positions are in the unit of the skeleton's BVH layout
// (mm without one).
//
// Resampling: output frame k is the file's frame nearest in time to k/25 s
// (ties to the later frame), over the file's duration (frames - 1) * frame
// time: nearest, not interpolated, so a 50 Hz file gives exactly its even
// frames and a 25 Hz file all of its frames.
//
// Throws InputError "<source_name>: not the skeleton \"<name>\": ..." (for
// H3.6M "not the H3.6M skeleton (h36m-32)") naming what differs: the joint
// and End Site counts of both, missing and unexpected joints, a joint with
// another parent; and when the result would exceed `limit` (checked before
// anything is allocated, naming it) or a root position change would exceed
// kMaxRootTranslationMm.
MotionFrames skeleton_motion_from_bvh(const Skeleton& skeleton, const BvhFile& file, const std::string& source_name,
                                      const BvhFrameLimit& limit = {});

// Every frame of the file, at its own rate (1 / frame time), as motion frames
// of the skeleton: what skeleton_motion_from_bvh gives without resampling,
// for takes, which are resampled on rotations (motion_resampling.h). The
// root's change is between consecutive file frames. Throws InputError as
// above (the file's frame count was bounded when it was parsed).
MotionFrames skeleton_motion_from_bvh_at_file_rate(const Skeleton& skeleton, const BvhFile& file,
                                                  const std::string& source_name);

// `frames` frames at 25 Hz of the import that starts at the file's frame
// `first_frame` (its time is 0), as skeleton_motion_from_bvh would give them
// for the file cut there: only these frames are computed, so that a window
// of a long take costs what the window does. Throws InputError as above,
// and when the file from `first_frame` makes fewer than `frames` frames.
MotionFrames skeleton_motion_window_from_bvh(const Skeleton& skeleton, const BvhFile& file,
                                             const std::string& source_name, int64_t first_frame, int64_t frames);

// For each joint of `skeleton`, the index of the BVH joint that carries its
// rotation, or -1 for a leaf that is an End Site in the file or, in a file
// without End Sites, absent under a parent that is a leaf there (animation
// tools drop them: Blender's glTF and FBX exports of a BVH have none).
// Throws the
// InputError described above when the hierarchies differ.
std::vector<int> match_bvh_to_skeleton(const Skeleton& skeleton, const BvhFile& file, const std::string& source_name);

}  // namespace mm
