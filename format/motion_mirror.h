// A motion's mirror image: the same movement with left and right swapped,
// as if seen in a mirror, for training data that turns both ways.
//
// Why: H3.6M's six training subjects walk their circles one way round (the
// root's turn over 6 s of walking is -2.6 to -4.9 rad on average for every
// one of them), and a manifold trained on them reproduces their turns but
// not the test subject's turns the other way (docs/RESULTS.md, "Motions
// that travel"). The mirror image of every training clip turns the other
// way.
//
// How: the skeleton's rest pose must be its own mirror image across the
// plane through the root perpendicular to one axis (the lateral axis: the
// axis along which its left and right joints' offsets differ most), each
// "left" joint's offset the reflection of its "right" twin's, and every
// unpaired joint's offset in the plane, within 5 mm and 5% of the bone
// (end points, which no bone hangs from, excepted). Joints pair by name: "Left"/"Right"
// or "left"/"right" anywhere in it, or a leading "l"/"r" or "L"/"R" before a
// capital ("lShldr", "rShldr"). In the model's layout (exponential maps of
// each joint's rotation in rest axes shared with the world, as H3.6M's and
// a BVH's are) the reflection M conjugates every rotation, M R M, which for
// a rotation vector v keeps its lateral component and negates the other
// two; the root's translation (its move, or position) has its lateral
// component negated; and each joint takes its twin's values.
//
// Torch-free and reentrant: value types only.
#pragma once

#include <vector>

#include "format/motion_frames.h"
#include "format/pose_normalization.h"
#include "format/skeleton.h"

namespace mm {

// For each column of a frame in the skeleton's layout (3 + 3 * joints), the
// column its mirrored value comes from and the sign it takes.
struct MotionMirror {
  int lateral_axis = 0;  // 0, 1 or 2: x, y or z
  std::vector<int> source_column;
  std::vector<float> sign;
};

// The mirror of `skeleton`. InputError naming the joint when its rest pose
// is not its own mirror image (offsets off by more than 5 mm and 5% of the
// bone), a joint named as a side has no twin, or no joint pairs at all.
MotionMirror motion_mirror(const Skeleton& skeleton);

// `motion` (the skeleton's layout) mirrored, frame by frame. Mirroring twice
// gives the motion back. std::invalid_argument for another column count.
MotionFrames mirrored(const MotionMirror& mirror, const MotionFrames& motion);

// The same map on normalised frames (PoseNormalization::normalize's dims):
// dims[d] of the mirror = scale[d] * dims[source_dim[d]] + shift[d], equal
// to normalising the mirror of the denormalised frame. InputError when a
// kept column's twin is not kept.
struct NormalizedMirror {
  std::vector<int> source_dim;
  std::vector<float> scale, shift;
};
NormalizedMirror normalized_mirror(const MotionMirror& mirror, const PoseNormalization& normalization);

}  // namespace mm
