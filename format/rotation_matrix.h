// RotationMatrix: 3x3 rotations in double precision without LibTorch, for
// file conversions (BVH) and torch-free forward kinematics.
//
// Two conventions meet here, and every function says which it uses:
// - column vectors (BVH, three.js, most of graphics): v' = R v, and a
//   child's world rotation is R_world[parent] * R_local;
// - row vectors (the H3.6M skeleton and model/rotation.h): v' = v R, and
//   R_world[j] = R_local[j] * R_world[parent].
// The same rotation is R in one and R^T in the other.
//
// Angles are in radians unless a name says degrees. All functions are pure
// and reentrant; none throws.
#pragma once

#include <array>
#include <string>

namespace mm {

using Mat3 = std::array<std::array<double, 3>, 3>;
using Vec3 = std::array<double, 3>;

Mat3 identity_matrix();
Mat3 multiply(const Mat3& a, const Mat3& b);
Mat3 transpose(const Mat3& m);
// m * v (column vector).
Vec3 multiply(const Mat3& m, const Vec3& v);
// v * m (row vector).
Vec3 multiply(const Vec3& v, const Mat3& m);

// Rodrigues' formula: I + sin(t) K + (1 - cos t) K^2 with K the cross-product
// matrix of the unit axis, exactly the matrix of model/rotation.h's
// expmap_to_rotation_matrix (which H3.6M applies to row vectors). As a
// column-vector matrix it turns by +|e| about e. Exact near zero (Taylor).
Mat3 expmap_to_matrix(const Vec3& expmap);

// Inverse of expmap_to_matrix: the exponential map with angle in [0, pi]
// (through a quaternion, accurate at every angle including pi).
Vec3 matrix_to_expmap(const Mat3& m);

// Column-vector rotation by `radians` about axis 0 (x), 1 (y) or 2 (z).
Mat3 axis_rotation(int axis, double radians);

// An Euler order as the BVH channel order gives it: axes[0] is the first
// rotation channel. The matrix is R_axes[0](a0) * R_axes[1](a1) *
// R_axes[2](a2) (column vectors), as BVH readers compose channels.
struct EulerOrder {
  std::array<int, 3> axes{2, 1, 0};  // default Z Y X

  // "ZYX" and the like; returns false (and leaves *order alone) for anything
  // but a permutation of X, Y and Z (case-insensitive).
  static bool parse(const std::string& text, EulerOrder* order);
  std::string name() const;  // "ZYX"
};

// R = R_axes[0](a0) R_axes[1](a1) R_axes[2](a2), angles in degrees.
Mat3 euler_degrees_to_matrix(const EulerOrder& order, const Vec3& degrees);

// Angles (degrees) with euler_degrees_to_matrix(order, result) == m to
// rounding; the middle angle lies in [-90, 90]. At gimbal lock (middle angle
// +-90) the last angle is set to 0.
Vec3 matrix_to_euler_degrees(const EulerOrder& order, const Mat3& m);

}  // namespace mm
