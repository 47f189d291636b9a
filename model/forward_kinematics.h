// Differentiable forward kinematics over a skeleton's joints.
//
// Thread safety: immutable after construction; positions() may be called
// concurrently.
#pragma once

#include <ATen/ATen.h>

#include <vector>

#include "format/skeleton.h"

namespace mm {

class ForwardKinematics {
 public:
  explicit ForwardKinematics(const Skeleton& skeleton);

  // frames: (..., 3 + 3 * J) un-normalised frames in the H3.6M layout (root
  // translation, then J exponential maps in radians). Returns (..., J, 3)
  // joint positions in millimetres with the root at the origin: the root
  // translation is ignored because the model does not learn it. Follows the
  // skeleton file's row-vector convention:
  //   R_world[j] = R_local[j] . R_world[parent],  p[j] = offset[j] . R_world[parent] + p[parent].
  // Throws InputError when the last dimension does not match the skeleton.
  at::Tensor positions(const at::Tensor& frames) const;

  int joint_count() const { return static_cast<int>(parents_.size()); }

  // Keeps the bone offsets on `device`, where positions() will run: copying
  // them there on every call would make each call wait for the GPU. Not
  // safe to call while positions() runs on another thread.
  void to(at::Device device);

 private:
  std::vector<int> parents_;
  at::Tensor offsets_mm_;  // (J, 3), float64 on the device of to(), cast to the frames' type and device on use
};

}  // namespace mm
