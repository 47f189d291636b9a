// Reference forward kinematics of the H3.6M skeleton file's convention in
// double precision (row vectors: R_world[j] = R_local[j] . R_world[parent],
// p[j] = offset[j] . R_world[parent] + p[parent]), written independently of
// the BVH code it checks. Root at the origin, as model/forward_kinematics.h.
#pragma once

#include <vector>

#include "format/rotation_matrix.h"
#include "format/skeleton.h"

namespace mm::test {

inline std::vector<Vec3> h36m_positions_mm(const float* frame) {
  static const Skeleton skeleton = Skeleton::h36m();
  std::vector<Vec3> position(skeleton.joints.size());
  std::vector<Mat3> rotation(skeleton.joints.size());
  for (size_t j = 0; j < skeleton.joints.size(); ++j) {
    const float* e = frame + 3 + 3 * j;
    const Mat3 local = expmap_to_matrix({e[0], e[1], e[2]});
    const int parent = skeleton.joints[j].parent;
    if (parent < 0) {
      position[j] = {0, 0, 0};
      rotation[j] = local;
      continue;
    }
    const Vec3 moved = multiply(skeleton.joints[j].offset_mm, rotation[parent]);
    for (int k = 0; k < 3; ++k) position[j][k] = position[parent][k] + moved[k];
    rotation[j] = multiply(local, rotation[parent]);
  }
  return position;
}

}  // namespace mm::test
