// NodeAnimation: a skeleton as a tree of nodes, each with a rest transform
// (translation, rotation, scale) and a local translation and rotation at
// every frame of a fixed rate: the common ground of BVH (bvh_file.h) and the
// node animations of glTF 2.0 (gltf_animation.h) and FBX (fbx_animation.h).
//
// Conventions: column vectors; lengths in metres (glTF's unit; BVH lengths
// are scaled by the file's unit); no axis change (a BVH's axes are the
// node tree's axes, as Blender's BVH importer and glTF exporter together
// leave them); quaternions as glTF stores them, {x, y, z, w}.
//
// Plain value types; all functions are reentrant. Errors are InputError
// naming the source.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "format/bvh_file.h"
#include "format/rotation_matrix.h"

namespace mm {

using Quaternion = std::array<double, 4>;  // x, y, z, w

// The quaternion of a column-vector rotation matrix, w >= 0.
Quaternion matrix_to_quaternion(const Mat3& m);
// The rotation matrix of a quaternion of any non-zero length (normalised
// first); identity for a zero quaternion.
Mat3 quaternion_to_matrix(const Quaternion& q);

// A node of the skeleton. `bvh_channels` and `end_site` carry the BVH layout
// of a file we wrote (glTF node extras), so that it reads back as the same
// BVH; `has_bvh_layout` says whether they were known.
struct AnimationNode {
  std::string name;
  int parent = -1;                   // index in NodeAnimation::nodes; parents precede children
  Vec3 rest_translation{};           // metres, in the parent's frame
  Quaternion rest_rotation{0, 0, 0, 1};
  Vec3 rest_scale{1, 1, 1};
  bool has_bvh_layout = false;
  bool end_site = false;
  std::vector<BvhChannel> bvh_channels;
  bool animated_translation = false;  // whether the file animates it (writers write only these)
  bool animated_rotation = false;
};

struct NodeAnimation {
  std::vector<AnimationNode> nodes;  // node 0 is the root
  // The world transform of the root's parent (a Blender armature object, a
  // scene's axis conversion): world = above_root_linear * x + above_root_translation.
  Mat3 above_root_linear = identity_matrix();
  Vec3 above_root_translation{};
  double rate_hz = 25.0;
  int64_t frames = 0;
  // frames x nodes, row-major: the local translation (metres) and rotation of
  // every node at frame f (time f / rate_hz); the rest pose where unanimated.
  std::vector<Vec3> translations;
  std::vector<Quaternion> rotations;
  // The BVH unit recorded by the writer of the file, mm per unit; 0 unknown.
  double millimetres_per_unit = 0;
};

// The BVH as a node animation: one node per joint and End Site (named
// "<parent>_End", "_2"... when taken, as bvh_skeleton() names them), rest
// translations the offsets, rest rotations identity, every frame's local
// translation offset + position channels and rotation the product of the
// rotation channels; lengths times `millimetres_per_unit` / 1000.
NodeAnimation node_animation_from_bvh(const BvhFile& file, double millimetres_per_unit);

// The node animation as a BVH in units of `millimetres_per_unit` mm: joint
// world positions equal to the nodes' (world transforms including the
// transform above the root and rest rotations and scales) at every frame.
// Offsets are the rest pose's world-axis differences between a joint and
// its parent, so rest rotations become part of the rotation channels. The
// channel layout is the nodes' BVH layout where every node has one, else:
// the root Xposition Yposition Zposition Zrotation Yrotation Xrotation,
// other joints Zrotation Yrotation Xrotation, unanimated leaves End Sites.
// Names are made BVH words (whitespace and braces become '_', empty names
// "joint<i>", repeats get "_2"...). Throws InputError naming `source_name`
// for no nodes, more than kMaxBvhJoints or a rate outside 1 to 1000 Hz.
BvhFile bvh_from_node_animation(const NodeAnimation& animation, double millimetres_per_unit,
                                const std::string& source_name);

// Keyframes of one node as a file holds them, times in seconds.
struct NodeKeyframes {
  std::vector<double> translation_times;
  std::vector<Vec3> translations;  // metres
  bool translation_step = false;   // held until the next key, else linear
  std::vector<double> rotation_times;
  std::vector<Quaternion> rotations;
  bool rotation_step = false;      // held, else slerp
};

// Samples `keys` (one per node of `animation`) at every 1 / rate from the
// first key to the last, the rate that of the keyframes (a single key: one
// frame at 25 Hz), into animation's rate_hz, frames, translations and
// rotations (rest values where a node has no keys) and marks the animated
// nodes. Throws InputError naming `source_name` for times that are not
// finite or decrease, values that are not finite, keys that disagree in
// count with their times, frames beyond `limit`, or frames x nodes beyond
// what a file of `input_bytes` may ask (a quarter of its bytes, at least
// 4 million): a small file cannot make a large allocation.
void sample_node_keyframes(NodeAnimation& animation, const std::vector<NodeKeyframes>& keys, size_t input_bytes,
                           const std::string& source_name, const BvhFrameLimit& limit);

// Removes root nodes that hold the skeleton but never move (an armature
// object above its root bone; a node with a BVH layout is kept): while the
// root has one child and the same pose in every frame, its pose joins the
// transform above the root and its child becomes the root.
void drop_still_roots(NodeAnimation& animation);

// The rate of keyframe times: (count - 1) / (last - first) of the longest
// series, rounded to a thousandth of a hertz (times stored as 32-bit floats
// read back at 120.000 Hz, not 119.99998). 0 when no series has two keys.
double keyframe_rate(const std::vector<std::vector<double>>& key_times);

// The frames a node animation of `duration_s` at `rate_hz` holds:
// round(duration x rate) + 1. Throws InputError naming `source_name` when the
// rate is outside 1 to 1000 Hz or the frames make more than `limit` at 25 Hz
// (checked before anything is allocated).
int64_t node_animation_frame_count(double duration_s, double rate_hz, const std::string& source_name,
                                   const BvhFrameLimit& limit);

}  // namespace mm
