// glTF 2.0 files (.glb binary, .gltf JSON with its buffer embedded) of a
// skeleton's node animation (node_animation.h), through tinygltf.
//
// Written: one node per joint and End Site (translation the rest offset in
// metres, no rest rotation), a skin over all of them (inverse bind matrices
// of the rest pose) so that Blender imports an armature and three.js Bones,
// and one animation "motion" whose channels hold every frame (times f /
// rate, LINEAR): rotation for the joints with rotation channels, translation
// for those with position channels. Each node's extras {"bvh": {"channels":
// [...], "end_site": bool}} and the asset's extras {"bvh_millimetres_per_unit"}
// let a BVH come back with its own layout and unit.
//
// Read: any glTF 2.0 with an animation. The skeleton is the subtree of the
// nearest common ancestor of the first skin's joints (or, without a skin,
// of the nodes the first animation moves), meshes and cameras left out; the
// first animation's translation and rotation channels are sampled at every
// 1 / rate from the first keyframe to the last, the rate that of the
// keyframes (keyframe_rate). Interpolation: LINEAR as the spec says
// (rotations by slerp), STEP, and CUBICSPLINE through its values only.
// External files (buffers by file name) are never opened: such a file is
// refused. Sparse accessors are refused.
//
// Reentrant. Errors are InputError naming `source_name` and what was found.
#pragma once

#include <cstddef>
#include <string>

#include "format/bvh_file.h"
#include "format/node_animation.h"

namespace mm {

// The file's bytes: .glb when `binary`, else .gltf JSON.
std::string write_gltf_animation(const NodeAnimation& animation, bool binary);

// Reads .glb (by its "glTF" magic) or .gltf JSON. `limit` bounds the frames
// (node_animation_frame_count), checked before they are sampled.
NodeAnimation read_gltf_animation(const char* data, size_t size, const std::string& source_name,
                                  const BvhFrameLimit& limit = {});

}  // namespace mm
