// Exponential-map rotations as differentiable tensor operations.
//
// Thread safety: pure functions of their arguments; safe to call concurrently.
#pragma once

#include <ATen/ATen.h>

namespace mm {

// Rodrigues' formula, batched: (..., 3) exponential-map vectors in radians to
// (..., 3, 3) rotation matrices, laid out for row vectors as in the H3.6M
// skeleton's FK convention (v' = v . R). Exact and with finite gradients at a
// zero angle, where the naive sin(t)/t form divides by zero.
at::Tensor expmap_to_rotation_matrix(const at::Tensor& expmap);

// Inverse of expmap_to_rotation_matrix for angles in [0, pi): (..., 3, 3) to
// (..., 3) radians. Used to check round trips and to measure angle errors.
at::Tensor rotation_matrix_to_expmap(const at::Tensor& rotation);

// Geodesic angle between two batches of rotation matrices, (..., 3, 3) each,
// in radians (..., ).
at::Tensor rotation_angle_between(const at::Tensor& a, const at::Tensor& b);

}  // namespace mm
