// Rotations and forward kinematics written out a second time, in double
// precision with plain loops and explicit 3x3 matrices, from the conventions
// the skeleton file documents (shared/data/h36m-skeleton.json, "fk_convention"):
//   row vectors, v' = v . R;
//   R_world[j] = R_local[j] . R_world[parent];
//   p[j] = offset[j] . R_world[parent] + p[parent], root at the origin.
// The model's tensor code is checked against this, so the two must not share
// code: the rotation here comes from the vector form of Rodrigues' formula,
// not from the skew-matrix form model/rotation.cpp uses.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "format/skeleton.h"

namespace mm::test {

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<Vec3, 3>;  // m[row][column]

inline Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

inline double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// v . R(expmap) for a row vector v. The H3.6M layout (Martinez et al.'s
// expmap2rotmat, used as v . R) turns a row vector by the angle |w| about
// the axis k = w / |w| in the sense that takes x to -y for a quarter turn
// about z: v' = v cos t + (v x k) sin t + k (k . v)(1 - cos t).
inline Vec3 rotate_row_vector(const Vec3& v, const Vec3& expmap) {
  const double angle = std::sqrt(dot(expmap, expmap));
  if (angle == 0.0) return v;
  const Vec3 k{expmap[0] / angle, expmap[1] / angle, expmap[2] / angle};
  const Vec3 v_cross_k = cross(v, k);
  const double along = dot(k, v) * (1.0 - std::cos(angle));
  Vec3 out;
  for (int i = 0; i < 3; ++i) out[i] = v[i] * std::cos(angle) + v_cross_k[i] * std::sin(angle) + k[i] * along;
  return out;
}

// The matrix of that map for row vectors: row i is the image of e_i.
inline Mat3 reference_rotation(const Vec3& expmap) {
  Mat3 r;
  for (int i = 0; i < 3; ++i) {
    Vec3 basis{0.0, 0.0, 0.0};
    basis[i] = 1.0;
    r[i] = rotate_row_vector(basis, expmap);
  }
  return r;
}

// Row vector times matrix.
inline Vec3 row_times(const Vec3& v, const Mat3& m) {
  Vec3 out{0.0, 0.0, 0.0};
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k < 3; ++k) out[c] += v[k] * m[k][c];
  }
  return out;
}

inline Mat3 times(const Mat3& a, const Mat3& b) {
  Mat3 out{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      for (int k = 0; k < 3; ++k) out[r][c] += a[r][k] * b[k][c];
    }
  }
  return out;
}

// Geodesic angle between two rotations: acos((trace(A B^T) - 1) / 2), the
// trace written as the sum of elementwise products.
inline double reference_angle_between(const Mat3& a, const Mat3& b) {
  double trace = 0.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) trace += a[r][c] * b[r][c];
  }
  return std::acos(std::max(-1.0, std::min(1.0, (trace - 1.0) / 2.0)));
}

// Joint positions (mm) of one raw H3.6M-layout frame (3 + 3 * J values;
// the root translation is ignored, as the model does).
inline std::vector<Vec3> reference_positions(const Skeleton& skeleton, const std::vector<double>& frame) {
  const int joints = skeleton.joint_count();
  std::vector<Mat3> world(joints);
  std::vector<Vec3> position(joints);
  for (int j = 0; j < joints; ++j) {
    const Mat3 local = reference_rotation({frame[3 + 3 * j], frame[4 + 3 * j], frame[5 + 3 * j]});
    const int parent = skeleton.joints[j].parent;
    const Vec3 offset{skeleton.joints[j].offset_mm[0], skeleton.joints[j].offset_mm[1], skeleton.joints[j].offset_mm[2]};
    if (parent < 0) {
      world[j] = local;
      position[j] = offset;
    } else {
      const Vec3 turned = row_times(offset, world[parent]);
      for (int i = 0; i < 3; ++i) position[j][i] = turned[i] + position[parent][i];
      world[j] = times(local, world[parent]);
    }
  }
  return position;
}

}  // namespace mm::test
