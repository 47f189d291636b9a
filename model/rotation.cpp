#include "model/rotation.h"

namespace mm {
namespace {

// Below this squared angle the Taylor series is used: sin(t)/t and
// (1-cos t)/t^2 lose all precision in float32 long before t reaches zero.
constexpr double kSmallAngleSquared = 1e-6;

at::Tensor skew(const at::Tensor& v) {
  auto x = v.select(-1, 0), y = v.select(-1, 1), z = v.select(-1, 2);
  auto zero = at::zeros_like(x);
  // Row-vector convention of Martinez et al.'s expmap2rotmat: [[0,-z,y],[z,0,-x],[-y,x,0]].
  auto rows = at::stack({at::stack({zero, -z, y}, -1), at::stack({z, zero, -x}, -1),
                         at::stack({-y, x, zero}, -1)},
                        -2);
  return rows;
}

}  // namespace

at::Tensor expmap_to_rotation_matrix(const at::Tensor& expmap) {
  auto theta2 = (expmap * expmap).sum(-1, /*keepdim=*/true).unsqueeze(-1);  // (...,1,1)
  auto small = theta2 < kSmallAngleSquared;
  // Evaluate the exact branch on a safe angle so its gradient is finite everywhere.
  auto safe_theta2 = at::where(small, at::ones_like(theta2), theta2);
  auto safe_theta = safe_theta2.sqrt();
  auto a = at::where(small, 1.0 - theta2 / 6.0, at::sin(safe_theta) / safe_theta);
  auto b = at::where(small, 0.5 - theta2 / 24.0, (1.0 - at::cos(safe_theta)) / safe_theta2);
  auto k = skew(expmap);
  auto eye = at::eye(3, expmap.options()).expand_as(k);
  return eye + a * k + b * at::matmul(k, k);
}

at::Tensor rotation_matrix_to_expmap(const at::Tensor& rotation) {
  auto trace = rotation.diagonal(0, -2, -1).sum(-1);
  auto cos_theta = ((trace - 1.0) * 0.5).clamp(-1.0, 1.0);
  auto theta = at::acos(cos_theta);
  // The skew part of R is sin(t) * K_unit in the layout of skew() above:
  // x = (R[2][1] - R[1][2]) / (2 sin t), and so on.
  auto at_rc = [&](int row, int col) { return rotation.select(-2, row).select(-1, col); };
  auto v = at::stack({at_rc(2, 1) - at_rc(1, 2), at_rc(0, 2) - at_rc(2, 0), at_rc(1, 0) - at_rc(0, 1)}, -1) * 0.5;
  auto sin_theta = at::sin(theta);
  auto small = sin_theta.abs() < 1e-6;
  auto scale = at::where(small, at::ones_like(theta), theta / at::where(small, at::ones_like(sin_theta), sin_theta));
  return v * scale.unsqueeze(-1);
}

at::Tensor rotation_angle_between(const at::Tensor& a, const at::Tensor& b) {
  auto relative = at::matmul(a, b.transpose(-1, -2));
  auto trace = relative.diagonal(0, -2, -1).sum(-1);
  return at::acos(((trace - 1.0) * 0.5).clamp(-1.0, 1.0));
}

}  // namespace mm
