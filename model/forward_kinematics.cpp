#include "model/forward_kinematics.h"

#include <string>

#include "format/input_error.h"
#include "model/rotation.h"

namespace mm {

ForwardKinematics::ForwardKinematics(const Skeleton& skeleton) {
  const int joints = skeleton.joint_count();
  offsets_mm_ = at::empty({joints, 3}, at::kDouble);
  auto offsets = offsets_mm_.accessor<double, 2>();
  for (int j = 0; j < joints; ++j) {
    parents_.push_back(skeleton.joints[j].parent);
    for (int k = 0; k < 3; ++k) offsets[j][k] = skeleton.joints[j].offset_mm[k];
  }
}

void ForwardKinematics::to(at::Device device) { offsets_mm_ = offsets_mm_.to(device); }

at::Tensor ForwardKinematics::positions(const at::Tensor& frames) const {
  const int joints = joint_count();
  const int64_t columns = frames.size(-1);
  if (columns != 3 + 3 * joints) {
    throw InputError("frames", "expected " + std::to_string(3 + 3 * joints) + " values per frame for a " +
                     std::to_string(joints) + "-joint skeleton, found " + std::to_string(columns));
  }
  auto batch_shape = frames.sizes().vec();
  batch_shape.pop_back();
  auto flat = frames.reshape({-1, columns});
  const int64_t n = flat.size(0);
  auto local = expmap_to_rotation_matrix(flat.narrow(1, 3, 3 * joints).reshape({n, joints, 3}));
  auto offsets = offsets_mm_.to(frames.device(), frames.scalar_type());

  std::vector<at::Tensor> world_rotation(joints), position(joints);
  for (int j = 0; j < joints; ++j) {
    auto r_local = local.select(1, j);  // (n, 3, 3)
    const int parent = parents_[j];
    if (parent < 0) {
      world_rotation[j] = r_local;
      position[j] = offsets[j].expand({n, 3});
    } else {
      // offset (1,3) . R_world[parent] (n,3,3) -> (n,3)
      position[j] = at::matmul(offsets[j].view({1, 1, 3}), world_rotation[parent]).squeeze(1) + position[parent];
      world_rotation[j] = at::matmul(r_local, world_rotation[parent]);
    }
  }
  auto result = at::stack(position, 1);  // (n, J, 3)
  batch_shape.push_back(joints);
  batch_shape.push_back(3);
  return result.reshape(batch_shape);
}

}  // namespace mm
