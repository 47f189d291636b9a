// FBX files (binary FBX 7.4, as Blender, Maya and MotionBuilder exchange
// them) of a skeleton's node animation (node_animation.h), through assimp.
//
// Reading only: Debian's assimp 5.2.5 writes binary FBX that neither it nor
// Blender 3.4 reads back (the nested records lack their closing sentinel:
// "FBX-Tokenize block offset is out of range", "failed to read nested block
// sentinel"), so motions are written as BVH or glTF, never FBX.
//
// Read: any FBX file with an animation. The skeleton is the subtree of the
// nearest common ancestor of the nodes the first animation moves (meshes
// left out), lengths scaled to metres by the file's UnitScaleFactor, keys
// sampled at every 1 / rate from the first to the last, the keyframes' rate.
//
// Each file is read in a child process (node_animation_in_child.h): an
// assertion assimp trips on a malformed file ends the child, not the
// caller. Reentrant. Errors are InputError naming `source_name` and
// assimp's message.
#pragma once

#include <cstddef>
#include <string>

#include "format/bvh_file.h"
#include "format/node_animation.h"

namespace mm {

NodeAnimation read_fbx_animation(const char* data, size_t size, const std::string& source_name,
                                 const BvhFrameLimit& limit = {});

}  // namespace mm
