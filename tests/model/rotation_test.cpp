#include "model/rotation.h"

#include <gtest/gtest.h>

#include <cmath>

namespace mm {
namespace {

TEST(Rotation, ZeroVectorIsIdentity) {
  auto r = expmap_to_rotation_matrix(at::zeros({4, 3}));
  EXPECT_TRUE(at::allclose(r, at::eye(3).expand({4, 3, 3})));
}

TEST(Rotation, QuarterTurnAboutZMapsXToY) {
  // Row-vector convention: v' = v . R.
  auto r = expmap_to_rotation_matrix(at::tensor({0.0f, 0.0f, static_cast<float>(M_PI / 2)}));
  auto x = at::tensor({1.0f, 0.0f, 0.0f}).view({1, 3});
  auto rotated = at::matmul(x, r).view({3});
  // Martinez et al.'s expmap2rotmat layout: x . R(z, 90 deg) = -y.
  EXPECT_TRUE(at::allclose(rotated, at::tensor({0.0f, -1.0f, 0.0f}), 1e-5, 1e-6)) << rotated;
  EXPECT_NEAR(at::det(r).item<float>(), 1.0f, 1e-5);
}

TEST(Rotation, MatricesAreOrthonormal) {
  at::manual_seed(0);
  auto r = expmap_to_rotation_matrix(at::randn({100, 3}, at::kDouble) * 2);
  auto product = at::matmul(r, r.transpose(-1, -2));
  EXPECT_TRUE(at::allclose(product, at::eye(3, at::kDouble).expand({100, 3, 3}), 1e-9, 1e-9));
}

TEST(Rotation, ExpmapRoundTripsThroughMatrix) {
  at::manual_seed(1);
  auto axis = at::randn({200, 3}, at::kDouble);
  axis = axis / axis.norm(2, -1, true);
  auto angle = at::rand({200, 1}, at::kDouble) * 3.0;  // below pi
  auto expmap = axis * angle;
  auto back = rotation_matrix_to_expmap(expmap_to_rotation_matrix(expmap));
  EXPECT_TRUE(at::allclose(back, expmap, 1e-6, 1e-6)) << (back - expmap).abs().max();
}

TEST(Rotation, GradientIsFiniteAtZeroAngle) {
  auto expmap = at::zeros({2, 3}).requires_grad_(true);
  auto r = expmap_to_rotation_matrix(expmap);
  (r * at::arange(9, at::kFloat).view({3, 3})).sum().backward();
  EXPECT_TRUE(at::isfinite(expmap.grad()).all().item<bool>());
  EXPECT_GT(expmap.grad().abs().sum().item<float>(), 0.0f);
}

TEST(Rotation, AngleBetweenMatchesConstructedAngle) {
  auto a = expmap_to_rotation_matrix(at::tensor({0.0, 0.3, 0.0}, at::kDouble));
  auto b = expmap_to_rotation_matrix(at::tensor({0.0, -0.2, 0.0}, at::kDouble));
  EXPECT_NEAR(rotation_angle_between(a, b).item<double>(), 0.5, 1e-9);
}

}  // namespace
}  // namespace mm
